# The add-on's example: loads one asset by name from a published release
# (mirrors in order, every file verified, cached under user://), and draws
# it beside the mesh it was baked from, then quits. Headless:
#
#   xvfb-run -a godot3 --path engines/godot/example -- \
#     --mirrors=http://127.0.0.1:8000/release --channel=nightly --name=props/box \
#     --mesh=/path/to/BoxTextured.glb --out=/tmp/impostor-example
#
# Writes into --out (default user://example_out):
#   views.png   per camera (one row each): the mesh | the impostor, both
#               unshaded, each over a transparent background (alpha =
#               coverage), --size pixels square, from --cameras;
#   scene.png   the lit scene: mesh and impostor side by side on a ground
#               plane with a directional light's shadows, and a forest of
#               impostors (one MultiMesh) behind them;
#   result.json {ok, error, asset, cache_key, channel, catalog_sha256,
#               files: [{name, sha256, verified, source, url}], cameras,
#               size, views_png, scene_png, forest: {instances, draw_calls
#               (the forest's share of the frame: depth prepass + colour),
#               draw_calls_frame}, good_up_to_pixels, switch_distance
#               (ImpostorAsset.switch_distance for the views' camera and
#               size), timings_ms}.
# A refused asset (a blob no mirror served intact, a catalog without the
# name...) is printed and written to result.json; the frames are still
# rendered with nothing in the impostor's place, and the exit code is 1.
# Options (also read from IMPOSTOR_EXAMPLE_<NAME> environment variables):
#   --mirrors=URL[,URL...] --channel=NAME (nightly) --name=ASSET --mesh=GLB
#   --out=DIR --cache-dir=DIR (user://impostor_cache) --size=PX (192)
#   --cameras=AZ,EL;AZ,EL... (degrees; camera at 4 radii, 30 degree fov)
#   --forest=N (instances in the draw-call count, 1024)
#   --scene=0 (views.png only: no lit scene, no forest)
extends Spatial

const ReleaseClient = preload("res://addons/impostor/release_client.gd")
const ImpostorAsset = preload("res://addons/impostor/impostor_asset.gd")
const Impostor = preload("res://addons/impostor/impostor.gd")
const ImpostorForest = preload("res://addons/impostor/impostor_forest.gd")
const GlbMesh = preload("res://glb_mesh.gd")

# Between the baked frames of the usual grids; the first four are the
# impostor-three browser test's.
const DEFAULT_CAMERAS = "35,20;125,40;210,-15;300,65;80,5;170,-40;255,30;345,50"

var opts = {}
var result = {}


func _ready():
	opts = _options()
	var t0 = OS.get_ticks_msec()
	Directory.new().make_dir_recursive(opts.out)
	result = {"ok": false, "error": "", "asset": opts.name, "channel": opts.channel, "cache_key": "",
			"catalog_sha256": "", "files": [], "cameras": opts.cameras, "size": opts.size, "timings_ms": {}}
	var client = ReleaseClient.new()
	client.mirrors = opts.mirrors
	client.channel = opts.channel
	client.cache_dir = opts.cache_dir
	add_child(client)
	var loaded = yield(client.load_asset(opts.name), "completed")
	var asset = ImpostorAsset.new()
	var err = asset.build(loaded)
	result.timings_ms = {"load": OS.get_ticks_msec() - t0}
	if err != "":
		asset = null
		result.error = err
		printerr("impostor example: %s refused: %s" % [opts.name, err])
	else:
		result.ok = true
		result.cache_key = asset.cache_key
		result.catalog_sha256 = asset.catalog_sha256
		result.files = asset.files
		# Where a game would switch to the impostor with the views' camera
		# (30 degree fov) and height (--size).
		result.good_up_to_pixels = asset.good_up_to_pixels
		result.switch_distance = asset.switch_distance(30.0, int(opts.size))
		for f in asset.files:
			print("impostor example: %s %s verified (%s)" % [f.name, f.sha256, f.source])
	var reader = GlbMesh.new()
	var mesh_flat = reader.load_glb(opts.mesh, true) if opts.mesh != "" else null
	var mesh_lit = reader.load_glb(opts.mesh, false) if opts.mesh != "" else null
	if opts.mesh != "" and mesh_flat == null:
		_finish("mesh: " + reader.error)
		return
	var centre = Vector3()
	var radius = 1.0
	if asset != null:
		centre = asset.sphere_center
		radius = asset.sphere_radius
	elif mesh_flat != null:
		var box = GlbMesh.bounds(mesh_flat)
		centre = box.position + 0.5 * box.size
		radius = max(0.5 * box.size.length(), 1e-3)
	result.timings_ms.mesh = OS.get_ticks_msec() - t0 - result.timings_ms.load
	var t1 = OS.get_ticks_msec()
	yield(_render_views(asset, mesh_flat, centre, radius), "completed")
	result.timings_ms.views = OS.get_ticks_msec() - t1
	if opts.scene:
		t1 = OS.get_ticks_msec()
		yield(_render_scene(asset, mesh_lit, centre, radius), "completed")
		result.timings_ms.scene = OS.get_ticks_msec() - t1
	_finish("")


func _finish(extra_error):
	if extra_error != "":
		result.ok = false
		result.error = extra_error if result.error == "" else result.error + "; " + extra_error
		printerr("impostor example: " + extra_error)
	var f = File.new()
	if f.open(opts.out.plus_file("result.json"), File.WRITE) == OK:
		f.store_string(JSON.print(result, "  ") + "\n")
		f.close()
	print("impostor example: %s, results in %s" % ["ok" if result.ok else "refused", opts.out])
	get_tree().quit(0 if result.ok else 1)


func _options():
	var o = {"mirrors": "", "channel": "nightly", "name": "", "mesh": "", "out": "user://example_out",
			"cache-dir": "user://impostor_cache", "size": "192", "cameras": DEFAULT_CAMERAS, "forest": "1024",
			"scene": "1"}
	for key in o.keys():
		var env = OS.get_environment("IMPOSTOR_EXAMPLE_" + key.to_upper().replace("-", "_"))
		if env != "":
			o[key] = env
	for arg in OS.get_cmdline_args():
		if arg.begins_with("--") and "=" in arg:
			var key = arg.substr(2, arg.find("=") - 2)
			if o.has(key):
				o[key] = arg.substr(arg.find("=") + 1)
	var cameras = []
	for pair in o.cameras.split(";", false):
		var ae = pair.split(",")
		cameras.append([float(ae[0]), float(ae[1])])
	var mirrors = []
	for m in o.mirrors.split(",", false):
		mirrors.append(m.strip_edges())
	return {"mirrors": mirrors, "channel": o.channel, "name": o.name, "mesh": o.mesh, "out": o.out,
			"cache_dir": o["cache-dir"], "size": int(o.size), "cameras": cameras, "forest": int(o.forest),
			"scene": o.scene != "0"}


# A camera at azimuth / elevation (degrees) `distance` from `target`, as
# the impostor-three test page places its cameras.
static func _place(camera, target, az, el, distance):
	var a = deg2rad(az)
	var e = deg2rad(el)
	var eye = target + distance * Vector3(sin(a) * cos(e), sin(e), cos(a) * cos(e))
	camera.look_at_from_position(eye, target, Vector3.UP)


func _camera(radius):
	var cam = Camera.new()
	cam.fov = 30.0
	cam.near = 0.05 * radius
	cam.far = 400.0 * radius
	cam.current = true
	return cam


# views.png: per camera, the mesh and the impostor, each in its own world.
func _render_views(asset, mesh, centre, radius):
	yield(get_tree(), "idle_frame")
	var s = opts.size
	var ports = []
	for c in opts.cameras:
		var row = []
		for side in range(2):
			var vp = Viewport.new()
			vp.size = Vector2(s, s)
			vp.own_world = true
			vp.transparent_bg = true
			vp.msaa = Viewport.MSAA_DISABLED
			vp.render_target_update_mode = Viewport.UPDATE_ALWAYS
			add_child(vp)
			if side == 0 and mesh != null:
				vp.add_child(mesh.duplicate())
			elif side == 1 and asset != null:
				var node = Impostor.new()
				node.unshaded = true
				node.asset = asset
				vp.add_child(node)
			var cam = _camera(radius)
			vp.add_child(cam)
			_place(cam, centre, c[0], c[1], 4.0 * radius)
			row.append(vp)
		ports.append(row)
	# Two frames: the first uploads the textures and compiles the shaders.
	yield(VisualServer, "frame_post_draw")
	yield(VisualServer, "frame_post_draw")
	var sheet = Image.new()
	sheet.create(2 * s, s * ports.size(), false, Image.FORMAT_RGBA8)
	for k in range(ports.size()):
		for side in range(2):
			var img = ports[k][side].get_texture().get_data()
			img.flip_y()
			img.convert(Image.FORMAT_RGBA8)
			sheet.blit_rect(img, Rect2(0, 0, s, s), Vector2(side * s, k * s))
	for row in ports:
		for vp in row:
			vp.queue_free()
	result.views_png = opts.out.plus_file("views.png")
	sheet.save_png(result.views_png)


# scene.png: the lit side-by-side scene in the window; then the forest of
# opts.forest instances alone, to count its draw calls.
func _render_scene(asset, mesh, centre, radius):
	yield(get_tree(), "idle_frame")
	var env = Environment.new()
	env.background_mode = Environment.BG_COLOR
	env.background_color = Color(0.55, 0.62, 0.7)
	env.ambient_light_color = Color(1, 1, 1)
	env.ambient_light_energy = 0.35
	var we = WorldEnvironment.new()
	we.environment = env
	add_child(we)
	var sun = DirectionalLight.new()
	sun.shadow_enabled = true
	sun.directional_shadow_mode = DirectionalLight.SHADOW_ORTHOGONAL
	sun.directional_shadow_max_distance = 40.0 * radius
	add_child(sun)
	sun.look_at_from_position(centre + Vector3(1, 2, 1.5), centre, Vector3.UP)
	var floor_y = centre.y - radius
	if mesh != null:
		floor_y = GlbMesh.bounds(mesh).position.y
		mesh.translation = Vector3(-1.25 * radius, 0, 0)
		add_child(mesh)
	var ground = MeshInstance.new()
	var plane = PlaneMesh.new()
	plane.size = Vector2(24.0 * radius, 24.0 * radius)
	ground.mesh = plane
	var ground_mat = SpatialMaterial.new()
	ground_mat.albedo_color = Color(0.45, 0.5, 0.4)
	ground.material_override = ground_mat
	ground.translation = Vector3(centre.x, floor_y, centre.z)
	add_child(ground)
	var forest = null
	if asset != null:
		var node = Impostor.new()
		node.asset = asset
		node.translation = Vector3(1.25 * radius, 0, 0)
		add_child(node)
		forest = ImpostorForest.new()
		forest.asset = asset
		forest.set_instance_transforms(_forest_transforms(16, 5, centre, radius, -5.0 * radius))
		add_child(forest)
	var cam = _camera(radius)
	add_child(cam)
	_place(cam, centre + Vector3(0, 0, -1.5 * radius), 15.0, 22.0, 9.0 * radius)
	yield(VisualServer, "frame_post_draw")
	var img = get_viewport().get_texture().get_data()
	img.flip_y()
	img.convert(Image.FORMAT_RGBA8)
	result.scene_png = opts.out.plus_file("scene.png")
	img.save_png(result.scene_png)
	result.forest = {"instances": 0, "draw_calls": -1}
	if forest != null and opts.forest > 0:
		# The same frame without the forest, then with it: the difference is
		# what the forest costs, whatever else the engine draws.
		for child in get_children():
			if child is VisualInstance:
				child.visible = false
		sun.shadow_enabled = false
		var n = int(ceil(sqrt(opts.forest)))
		forest.set_instance_transforms(_forest_transforms(opts.forest, n, centre, radius, 0.0))
		# Far enough that the whole forest is a few pixels wide: counting
		# draw calls needs no detail, and software GL pays per pixel.
		cam.far = 100.0 * n * radius
		_place(cam, centre, 20.0, 35.0, 40.0 * n * radius)
		# The monitor reports the frame before the last one drawn.
		for i in range(3):
			yield(VisualServer, "frame_post_draw")
		var without = Performance.get_monitor(Performance.RENDER_DRAW_CALLS_IN_FRAME)
		forest.visible = true
		for i in range(3):
			yield(VisualServer, "frame_post_draw")
		var with_forest = Performance.get_monitor(Performance.RENDER_DRAW_CALLS_IN_FRAME)
		result.forest = {"instances": opts.forest, "draw_calls": int(with_forest - without),
				"draw_calls_frame": int(with_forest)}


# `count` instances on a grid `per_row` wide, 2.5 radii apart, centred on x,
# starting `z0` behind the centre, each turned about Y and scaled a little
# (a fixed seed: the same picture every run).
static func _forest_transforms(count, per_row, centre, radius, z0):
	var rng = RandomNumberGenerator.new()
	rng.seed = 41
	var out = []
	var rows = int(ceil(float(count) / per_row))
	for i in range(count):
		var col = i % per_row
		var row = i / per_row
		var scale = rng.randf_range(0.8, 1.2)
		var basis = Basis(Vector3.UP, rng.randf_range(0.0, TAU)).scaled(Vector3(scale, scale, scale))
		var at = Vector3((col - 0.5 * (per_row - 1)) * 2.5 * radius, 0.0, z0 - (row - 0.5 * (rows - 1) if z0 == 0.0 else row) * 2.5 * radius)
		# Turned and scaled about the bounding sphere's centre.
		out.append(Transform(basis, at + centre - basis.xform(centre)))
	return out

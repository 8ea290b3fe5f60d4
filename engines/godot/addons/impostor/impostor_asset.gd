# One baked impostor ready to draw: its manifest, atlas layout, bounding
# sphere and map textures, plus where every file came from. Made from a
# release_client.gd load (verified bytes only) by build(); shared by any
# number of Impostor and ImpostorForest nodes, which take their materials
# from material() so that nodes with the same options share one.
#
# Textures: the maps as the baker wrote them, one level, no filter, no
# repeat, no colour conversion (the shader reads single texels and decodes
# albedo's sRGB itself; normal_depth keeps 8 bits of its 16, Godot 3's PNG
# loader strips the rest). A texture-array bake (`impostor bake
# --array`: one tile-wide strip, layer i = view i) is repacked into the
# atlas grid the shader addresses. KTX2 maps are refused: Godot 3 has no
# Basis Universal transcoder (publish a PNG bake for Godot 3).
extends Reference

const LAYOUT_KINDS = {"octahedral": 0, "hemi-octahedral": 1, "azimuth-elevation": 2, "ring-top": 3, "billboard": 4}
const BILLBOARD_RING_VIEWS = 8
const RECONSTRUCTIONS = {"plain": 0, "parallax": 1, "depth": 2}
const BLENDS = {"triangle3": 0, "bilinear4": 1}
const SHADER_PATH = "res://addons/impostor/impostor.shader"
# The switch size when the bake measured no good_up_to_pixels, as the C++
# SDK (impostor/lod.h) and impostor-three (DEFAULT_IMPOSTOR_SWITCH_PIXELS).
const DEFAULT_SWITCH_PIXELS = 16

var name = ""
var cache_key = ""
var channel = ""
var catalog_sha256 = ""
var manifest = {}
var product = "atlas"
var layout_name = ""
var layout_kind = 0
var frames = 0
var ring_views = 0
var tile_size = 0
var view_count = 0
var grid_side = 0
var sphere_center = Vector3()
var sphere_radius = 1.0
# What the farm's quality pass measured the bake with: the materials' default.
var blend = "triangle3"
var reconstruction = "depth"
# The on-screen size, in pixels across the bounding sphere's diameter, up to
# which the quality pass found the impostor good enough to stand in for the
# mesh (manifest quality.good_up_to_pixels); 0 when the bake measured none.
# switch_distance() turns it into a camera distance.
var good_up_to_pixels = 0
var albedo_texture = null        # ImageTexture
var normal_depth_texture = null  # ImageTexture
var orm_texture = null           # ImageTexture or null
# release_client.gd's report: [{name, semantic, sha256, size_bytes, verified, source, url}]
var files = []

var _materials = {}  # options key -> ShaderMaterial
var _card = null     # ArrayMesh


# Fills the asset from a successful release_client.gd load_asset() result.
# Returns "" or an error naming the file or field at fault.
func build(loaded):
	if not loaded.get("ok", false):
		return loaded.get("error", "not loaded")
	name = loaded.name
	channel = loaded.get("channel", "")
	catalog_sha256 = loaded.get("catalog_sha256", "")
	files = loaded.get("report", [])
	var bytes = loaded.files
	if not bytes.has("manifest.json"):
		return "%s: the release lists no manifest.json" % name
	var parsed = JSON.parse(bytes["manifest.json"].get_string_from_utf8())
	if parsed.error != OK or not parsed.result is Dictionary:
		return "%s: manifest.json: %s at line %d" % [name, parsed.error_string, parsed.error_line]
	return build_from_manifest(parsed.result, bytes)


# The same from a manifest and the map files' bytes by file name (a baked
# result on disk, for instance). Returns "" or an error.
func build_from_manifest(m, bytes):
	manifest = m
	cache_key = str(m.get("cache_key", ""))
	product = str(m.get("product", "atlas"))
	if product != "atlas":
		return "%s: product %s; this add-on draws atlas products" % [name, product]
	var err = _read_layout(m)
	if err != "":
		return "%s: %s" % [name, err]
	var bs = m.get("bounding_sphere")
	if not bs is Dictionary or not bs.get("center") is Array or bs.center.size() != 3 or not (bs.get("radius") is float) or not (bs.radius > 0.0):
		return "%s: manifest.json: no bounding_sphere {center, radius > 0}" % name
	sphere_center = Vector3(bs.center[0], bs.center[1], bs.center[2])
	sphere_radius = bs.radius
	var quality = m.get("quality", {})
	blend = "bilinear4" if quality is Dictionary and quality.get("blend") == "bilinear4" else "triangle3"
	reconstruction = "depth"
	# JSON numbers are floats here; anything but a positive whole number
	# (absent, a string, 12.5, -3) means "not measured".
	var good = quality.get("good_up_to_pixels", 0) if quality is Dictionary else 0
	good_up_to_pixels = int(good) if (good is float or good is int) and good > 0 and good == floor(good) else 0
	var maps = m.get("maps", [])
	if not maps is Array:
		return "%s: manifest.json: maps is not a list" % name
	for map in maps:
		if not map is Dictionary:
			continue
		var semantic = map.get("semantic", "")
		if not semantic in ["albedo_alpha", "normal_depth", "orm"]:
			continue
		var file = str(map.get("file", ""))
		if str(map.get("format", "")).begins_with("ktx2") or file.to_lower().ends_with(".ktx2"):
			return "%s: %s is KTX2, which Godot 3 cannot transcode (no Basis Universal): bake with --texture-format png" % [name, file]
		if not bytes.has(file):
			return "%s: map %s (%s) was not fetched" % [name, file, semantic]
		var tex = _texture(file, bytes[file], map)
		if tex is String:
			return "%s: %s" % [name, tex]
		match semantic:
			"albedo_alpha":
				albedo_texture = tex
			"normal_depth":
				normal_depth_texture = tex
			"orm":
				orm_texture = tex
	if albedo_texture == null or normal_depth_texture == null:
		return "%s: the manifest lists no albedo_alpha and normal_depth maps to draw" % name
	return ""


# The camera distance beyond which to draw the impostor instead of the mesh:
# where the bounding sphere's diameter (times the node's uniform scale)
# covers good_up_to_pixels (fallback_pixels when the bake measured none) of
# a viewport `viewport_height` pixels tall, seen through a perspective
# camera of vertical field of view `fov_degrees` (Camera.fov, keep_aspect
# KEEP_HEIGHT). The C++ SDK's SetImpostorSwitchPixels and impostor-three's
# impostorSwitchScale switch at the same place. -1.0 for arguments out of
# range (fov outside (0, 180), a height or scale that is not > 0).
func switch_distance(fov_degrees, viewport_height, node_scale = 1.0, fallback_pixels = DEFAULT_SWITCH_PIXELS):
	var pixels = good_up_to_pixels if good_up_to_pixels > 0 else fallback_pixels
	if not (fov_degrees > 0.0 and fov_degrees < 180.0) or not (viewport_height > 0) or not (node_scale > 0.0) or not (pixels > 0):
		return -1.0
	return 2.0 * sphere_radius * node_scale * viewport_height / (2.0 * tan(deg2rad(fov_degrees) * 0.5) * pixels)


# The dither's rotation for an instance seed (an unsigned 32-bit integer):
# the top 4 bits of seed * 2654435769 mod 2^32, as impostor_crossfade.glsl
# and the C++ SDK (impostor/lod.h) work it out. Multiplied in 16-bit halves
# so no product leaves GDScript's 64-bit int.
static func cross_fade_offset(instance_seed):
	var k = 2654435769
	var lo = (instance_seed & 0xffff) * k
	var hi = (((instance_seed >> 16) & 0xffff) * k) & 0xffff
	return ((lo + (hi << 16)) & 0xffffffff) >> 28


# The shared material for these options: reconstruction ("plain",
# "parallax", "depth"; "" = the asset's), blend ("triangle3", "bilinear4";
# "" = the asset's), depth_offset (DEPTH = the reconstructed surface's),
# unshaded (ALBEDO only, no lighting), cross_fade (the shader's
# impostor_cross_fade: 0 off, 1 one node's own fade uniforms (duplicate
# the material per node), 2 per MultiMesh instance, INSTANCE_CUSTOM).
func material(reconstruction_name = "", blend_name = "", depth_offset = true, unshaded = false, cross_fade = 0):
	var r = reconstruction_name if reconstruction_name != "" else reconstruction
	var b = blend_name if blend_name != "" else blend
	if not RECONSTRUCTIONS.has(r):
		push_error("impostor: reconstruction \"%s\": want one of %s" % [r, str(RECONSTRUCTIONS.keys())])
		r = reconstruction
	if not BLENDS.has(b):
		push_error("impostor: blend \"%s\": want one of %s" % [b, str(BLENDS.keys())])
		b = blend
	var key = "%s/%s/%s/%s/%d" % [r, b, depth_offset, unshaded, cross_fade]
	if _materials.has(key):
		return _materials[key]
	var mat = ShaderMaterial.new()
	mat.shader = _shader(unshaded)
	mat.set_shader_param("impostor_albedo", albedo_texture)
	mat.set_shader_param("impostor_normal_depth", normal_depth_texture)
	mat.set_shader_param("impostor_orm", orm_texture if orm_texture != null else albedo_texture)
	mat.set_shader_param("impostor_sphere", Quat(sphere_center.x, sphere_center.y, sphere_center.z, sphere_radius))
	mat.set_shader_param("impostor_layout", PoolIntArray([layout_kind, frames, ring_views, tile_size]))
	mat.set_shader_param("impostor_mode", PoolIntArray([BLENDS[b], RECONSTRUCTIONS[r], 1 if orm_texture != null else 0, 0]))
	mat.set_shader_param("impostor_depth_offset", depth_offset)
	mat.set_shader_param("impostor_cross_fade", cross_fade)
	_materials[key] = mat
	return mat


# The card every node draws: four corners in -1..1 that the shader turns to
# face the camera; its AABB is the bounding sphere's box, so culling sees
# the object, not the card.
func card_mesh():
	if _card != null:
		return _card
	var arrays = []
	arrays.resize(Mesh.ARRAY_MAX)
	arrays[Mesh.ARRAY_VERTEX] = PoolVector3Array([Vector3(-1, -1, 0), Vector3(1, -1, 0), Vector3(1, 1, 0), Vector3(-1, 1, 0)])
	arrays[Mesh.ARRAY_INDEX] = PoolIntArray([0, 2, 1, 0, 3, 2])
	_card = ArrayMesh.new()
	_card.add_surface_from_arrays(Mesh.PRIMITIVE_TRIANGLES, arrays)
	var r = Vector3(sphere_radius, sphere_radius, sphere_radius)
	_card.custom_aabb = AABB(sphere_center - r, 2.0 * r)
	return _card


# The manifest's layout as the shader takes it (AtlasLayoutFromManifest).
func _read_layout(m):
	layout_name = str(m.get("layout", "octahedral"))
	if layout_name == "":
		layout_name = "octahedral"
	if not LAYOUT_KINDS.has(layout_name):
		return "layout \"%s\" is not one this runtime draws" % layout_name
	layout_kind = LAYOUT_KINDS[layout_name]
	var f = m.get("frames")
	if not (f is float) or f != floor(f) or f < 1 or f > 64:
		return "frames %s: want 1..64" % str(f)
	frames = int(f)
	var views = m.get("views", [])
	view_count = views.size() if views is Array else 0
	ring_views = 0
	if layout_name == "ring-top":
		ring_views = view_count - 1
		if ring_views < 1:
			return "ring-top: the manifest lists no ring views"
	elif layout_name == "billboard":
		ring_views = BILLBOARD_RING_VIEWS
	var want = frames * frames if layout_kind <= 2 else ring_views + 1
	if view_count != want:
		return "%s with frames %d: %d views expected, the manifest lists %d" % [layout_name, frames, want, view_count]
	var ts = m.get("tile_size")
	if not (ts is float) or ts < 1 or ts != floor(ts):
		return "tile_size %s: want a whole number >= 1" % str(ts)
	tile_size = int(ts)
	grid_side = frames
	if ring_views > 0:
		grid_side = 1
		while grid_side * grid_side < ring_views + 1:
			grid_side += 1
	return ""


func _shader(unshaded):
	var base = load(SHADER_PATH)
	if not unshaded:
		return base
	var variant = Shader.new()
	variant.code = base.code.replace("render_mode skip_vertex_transform, cull_disabled;",
			"render_mode skip_vertex_transform, cull_disabled, unshaded;")
	return variant


# An ImageTexture of a map's PNG bytes, or an error String.
func _texture(file, png, map):
	var img = Image.new()
	var err = img.load_png_from_buffer(png)
	if err != OK:
		return "%s: not a PNG Godot can decode (error %d)" % [file, err]
	var want = Vector2(int(map.get("width", 0)), int(map.get("height", 0)))
	if want.x > 0 and img.get_size() != want:
		return "%s: %dx%d pixels, the manifest says %dx%d" % [file, img.get_width(), img.get_height(), want.x, want.y]
	if img.get_format() != Image.FORMAT_RGBA8:
		img.convert(Image.FORMAT_RGBA8)
	if view_count > 1 and img.get_width() == tile_size and img.get_height() == view_count * tile_size:
		img = _strip_to_atlas(img)
	var tex = ImageTexture.new()
	tex.create_from_image(img, 0)
	return tex


# A texture-array strip (layer i at rows i * tile_size) as the atlas grid:
# view i at tile (i % grid_side, i / grid_side).
func _strip_to_atlas(strip):
	var atlas = Image.new()
	atlas.create(grid_side * tile_size, grid_side * tile_size, false, Image.FORMAT_RGBA8)
	for i in range(view_count):
		atlas.blit_rect(strip, Rect2(0, i * tile_size, tile_size, tile_size),
				Vector2((i % grid_side) * tile_size, (i / grid_side) * tile_size))
	return atlas

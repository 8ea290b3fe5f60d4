# An impostor in the scene: a MeshInstance whose card (the asset's
# card_mesh()) the shader turns toward the camera, or toward the light in
# the shadow pass, drawn with the asset's shared ShaderMaterial (impostor.
# shader: frame selection and 3-frame blending, virtual-plane UVs, the
# depth-aware reconstruction, DEPTH at the reconstructed surface, the shadow
# caster). Place, rotate and scale it like any node; the scale must be
# uniform (the impostor is a similarity of the baked object).
#
#   var node = preload("res://addons/impostor/impostor.gd").new()
#   node.asset = asset  # impostor_asset.gd, built from a release
#   add_child(node)
extends MeshInstance

# The reconstruction the fragment stage runs: "depth" (the farm's quality
# pass measures this one; no ghosting between frames), "parallax" or
# "plain" (cheapest, ghosts where frames disagree). "" = the asset's.
export(String, "", "depth", "parallax", "plain") var reconstruction = "" setget set_reconstruction
# "triangle3" (3 frames, Brucks) or "bilinear4"; "" = what the asset's
# quality pass used.
export(String, "", "triangle3", "bilinear4") var blend = "" setget set_blend
# Writes DEPTH for the reconstructed surface point (the impostor intersects
# other geometry where the mesh would); off: the card's own depth.
export(bool) var depth_offset = true setget set_depth_offset
# ALBEDO only, no lighting (for comparisons and debugging).
export(bool) var unshaded = false setget set_unshaded
# Cross-fade at the LOD switch (shaders/impostor_crossfade.glsl): this node
# draws only its share of pixels for `fade` (0: none, the mesh draws every
# pixel; 1: all), in the shadow pass too; its mesh must discard the others
# with the same fade and seed. On, the node has its own material copy.
export(bool) var cross_fade = false setget set_cross_fade
export(float, 0, 1) var fade = 1.0 setget set_fade
export(int) var fade_seed = 0 setget set_fade_seed

var asset = null setget set_asset


func set_asset(value):
	asset = value
	_refresh()


func set_reconstruction(value):
	reconstruction = value
	_refresh()


func set_blend(value):
	blend = value
	_refresh()


func set_depth_offset(value):
	depth_offset = value
	_refresh()


func set_unshaded(value):
	unshaded = value
	_refresh()


func set_cross_fade(value):
	cross_fade = value
	_refresh()


func set_fade(value):
	fade = value
	if cross_fade and material_override != null:
		material_override.set_shader_param("impostor_fade", fade)


func set_fade_seed(value):
	fade_seed = value
	_refresh()


func _refresh():
	if asset == null:
		mesh = null
		material_override = null
		return
	mesh = asset.card_mesh()
	material_override = asset.material(reconstruction, blend, depth_offset, unshaded, 1 if cross_fade else 0)
	if cross_fade:
		material_override = material_override.duplicate()
		material_override.set_shader_param("impostor_fade", fade)
		material_override.set_shader_param("impostor_fade_offset", float(asset.cross_fade_offset(fade_seed)))

# Many instances of one impostor in one draw call: a MultiMeshInstance of
# the asset's card with the asset's shared material. Each instance's frames
# and weights are chosen in the vertex stage from the direction between
# its own centre and the camera, so instances may be rotated and (uniformly)
# scaled freely.
#
#   var forest = preload("res://addons/impostor/impostor_forest.gd").new()
#   forest.asset = asset
#   forest.set_instance_transforms(transforms)  # Array of Transform
#   add_child(forest)
#
# Cross-fade at the LOD switch (cross_fade = true): each instance draws only
# its share of pixels for its fade t (set_instance_fade; 0: none, its mesh
# draws every pixel; 1: all), the same dither as
# shaders/impostor_crossfade.glsl, in the shadow pass too. Its mesh must
# discard the complementary pixels with the same t and seed.
extends MultiMeshInstance

export(String, "", "depth", "parallax", "plain") var reconstruction = ""
export(String, "", "triangle3", "bilinear4") var blend = ""
export(bool) var depth_offset = true
export(bool) var unshaded = false
export(bool) var cross_fade = false setget set_cross_fade

var asset = null setget set_asset
var _transforms = []
var _fades = {}  # instance -> Color(t, offset, 0, 0)

const _Asset = preload("impostor_asset.gd")


# Instance i's fade t (0..1) with `instance_seed` (default: its index); needs
# cross_fade. Until set an instance is drawn whole (t = 1).
func set_instance_fade(i, t, instance_seed = -1):
	var offset = _Asset.cross_fade_offset(i if instance_seed < 0 else instance_seed)
	_fades[i] = Color(t, offset, 0, 0)
	if multimesh != null and i < multimesh.instance_count and cross_fade:
		multimesh.set_instance_custom_data(i, _fades[i])


func set_cross_fade(value):
	cross_fade = value
	_rebuild()


func set_asset(value):
	asset = value
	_rebuild()


# One instance per Transform, replacing the previous set.
func set_instance_transforms(transforms):
	_transforms = transforms.duplicate()
	_rebuild()


func _rebuild():
	if asset == null:
		multimesh = null
		material_override = null
		return
	var mm = MultiMesh.new()
	mm.transform_format = MultiMesh.TRANSFORM_3D
	if cross_fade:
		mm.custom_data_format = MultiMesh.CUSTOM_DATA_FLOAT
	mm.mesh = asset.card_mesh()
	mm.instance_count = _transforms.size()
	for i in range(_transforms.size()):
		mm.set_instance_transform(i, _transforms[i])
		if cross_fade:
			mm.set_instance_custom_data(i, _fades.get(i, Color(1, _Asset.cross_fade_offset(i), 0, 0)))
	multimesh = mm
	material_override = asset.material(reconstruction, blend, depth_offset, unshaded, 2 if cross_fade else 0)

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
extends MultiMeshInstance

export(String, "", "depth", "parallax", "plain") var reconstruction = ""
export(String, "", "triangle3", "bilinear4") var blend = ""
export(bool) var depth_offset = true
export(bool) var unshaded = false

var asset = null setget set_asset
var _transforms = []


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
	mm.mesh = asset.card_mesh()
	mm.instance_count = _transforms.size()
	for i in range(_transforms.size()):
		mm.set_instance_transform(i, _transforms[i])
	multimesh = mm
	material_override = asset.material(reconstruction, blend, depth_offset, unshaded)

# Editor side of the add-on: registers the Impostor and ImpostorForest
# node types. Nothing here runs in a game; the nodes work without the
# plugin enabled (preload their scripts).
tool
extends EditorPlugin


func _enter_tree():
	add_custom_type("Impostor", "MeshInstance", preload("impostor.gd"), null)
	add_custom_type("ImpostorForest", "MultiMeshInstance", preload("impostor_forest.gd"), null)


func _exit_tree():
	remove_custom_type("Impostor")
	remove_custom_type("ImpostorForest")

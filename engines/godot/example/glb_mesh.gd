# A small glTF 2.0 binary (.glb) reader for the example's reference mesh:
# Godot 3.2 imports glTF only in the editor, and the example runs headless
# without an import step. It reads what a static prop needs and nothing
# more: the default scene's node tree (matrix or TRS), triangle primitives
# (POSITION, NORMAL, TEXCOORD_0, indices of any integer type, normalised or
# float attributes, byteStride), and each material's base colour (factor
# and texture, PNG or JPEG in a bufferView) and alphaMode / doubleSided.
# Anything else (sparse accessors, skins, morph targets, KHR_ extensions,
# external buffers) is refused or ignored, naming it; the add-on itself
# never needs a mesh.
#
# Conventions: glTF and Godot are both right-handed, +Y up, metres, so
# positions pass unchanged (the manifest's object space is the glTF
# scene's); glTF's front faces are counter-clockwise, Godot 3's clockwise,
# so every triangle's winding is reversed; UV (0, 0) is the image's top-left
# in both. baseColorFactor is linear, SpatialMaterial's albedo_color sRGB.
extends Reference

const COMPONENT_SIZE = {5120: 1, 5121: 1, 5122: 2, 5123: 2, 5125: 4, 5126: 4}
const COMPONENTS = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4}

var error = ""
var _gltf = {}
var _bin = PoolByteArray()
var _buf = StreamPeerBuffer.new()
var _materials = {}  # "index/unshaded" -> SpatialMaterial
var _textures = {}   # texture index -> ImageTexture


# A Spatial holding one MeshInstance per mesh node, placed as in the file,
# or null (then `error` says why). unshaded: materials without lighting.
func load_glb(path, unshaded):
	error = ""
	var f = File.new()
	if f.open(path, File.READ) != OK:
		error = "%s: cannot open" % path
		return null
	var bytes = f.get_buffer(f.get_len())
	f.close()
	if not _parse(bytes):
		error = "%s: %s" % [path, error]
		return null
	var root = Spatial.new()
	root.name = path.get_file().get_basename()
	var scene_index = int(_gltf.get("scene", 0))
	var scenes = _gltf.get("scenes", [])
	if scenes.size() <= scene_index:
		error = "%s: no scene %d" % [path, scene_index]
		return null
	for n in scenes[scene_index].get("nodes", []):
		if not _add_node(root, int(n), Transform(), unshaded):
			error = "%s: %s" % [path, error]
			return null
	return root


# The union of the meshes' boxes under `root` (in root's space).
static func bounds(root):
	var box = null
	for child in root.get_children():
		if child is MeshInstance and child.mesh != null:
			var b = child.transform.xform(child.mesh.get_aabb())
			box = b if box == null else box.merge(b)
	return box if box != null else AABB()


func _parse(bytes):
	_buf.data_array = bytes
	_buf.seek(0)
	if bytes.size() < 20 or _buf.get_u32() != 0x46546C67:
		error = "not a glTF binary (.glb)"
		return false
	var version = _buf.get_u32()
	var length = _buf.get_u32()
	if version != 2 or length > bytes.size():
		error = "glb version %d, length %d of %d bytes" % [version, length, bytes.size()]
		return false
	var json_text = ""
	var offset = 12
	while offset + 8 <= length:
		_buf.seek(offset)
		var chunk_length = _buf.get_u32()
		var chunk_type = _buf.get_u32()
		var start = offset + 8
		if start + chunk_length > length:
			error = "chunk at %d runs past the end" % offset
			return false
		if chunk_type == 0x4E4F534A:
			json_text = bytes.subarray(start, start + chunk_length - 1).get_string_from_utf8()
		elif chunk_type == 0x004E4942 and chunk_length > 0:
			_bin = bytes.subarray(start, start + chunk_length - 1)
		offset = start + chunk_length
	var parsed = JSON.parse(json_text)
	if parsed.error != OK or not parsed.result is Dictionary:
		error = "JSON chunk: %s" % parsed.error_string
		return false
	_gltf = parsed.result
	for ext in _gltf.get("extensionsRequired", []):
		error = "required extension %s is not supported by this reader" % ext
		return false
	_buf.data_array = _bin
	return true


func _add_node(parent, index, parent_xform, unshaded):
	var node = _gltf.nodes[index]
	var xform = parent_xform * _node_transform(node)
	if node.has("mesh"):
		var mesh = _build_mesh(int(node.mesh), unshaded)
		if mesh == null:
			return false
		var mi = MeshInstance.new()
		mi.mesh = mesh
		mi.transform = xform
		parent.add_child(mi)
	for c in node.get("children", []):
		if not _add_node(parent, int(c), xform, unshaded):
			return false
	return true


static func _node_transform(node):
	if node.has("matrix"):
		var m = node.matrix
		return Transform(Basis(Vector3(m[0], m[1], m[2]), Vector3(m[4], m[5], m[6]), Vector3(m[8], m[9], m[10])),
				Vector3(m[12], m[13], m[14]))
	var t = node.get("translation", [0, 0, 0])
	var r = node.get("rotation", [0, 0, 0, 1])
	var s = node.get("scale", [1, 1, 1])
	var basis = Basis(Quat(r[0], r[1], r[2], r[3])) * Basis().scaled(Vector3(s[0], s[1], s[2]))
	return Transform(basis, Vector3(t[0], t[1], t[2]))


func _build_mesh(index, unshaded):
	var mesh = ArrayMesh.new()
	for prim in _gltf.meshes[index].get("primitives", []):
		if int(prim.get("mode", 4)) != 4:
			continue  # points and lines: not drawn
		var attrs = prim.attributes
		if not attrs.has("POSITION"):
			error = "mesh %d: a primitive without POSITION" % index
			return null
		var pos = _accessor(int(attrs.POSITION))
		if pos == null:
			return null
		var vertex_count = pos.size() / 3
		var verts = PoolVector3Array()
		for i in range(vertex_count):
			verts.append(Vector3(pos[3 * i], pos[3 * i + 1], pos[3 * i + 2]))
		var indices = PoolIntArray()
		if prim.has("indices"):
			var idx = _accessor(int(prim.indices))
			if idx == null:
				return null
			for i in range(0, idx.size() - 2, 3):
				indices.append(int(idx[i]))
				indices.append(int(idx[i + 2]))
				indices.append(int(idx[i + 1]))
		else:
			for i in range(0, vertex_count - 2, 3):
				indices.append(i)
				indices.append(i + 2)
				indices.append(i + 1)
		var arrays = []
		arrays.resize(Mesh.ARRAY_MAX)
		arrays[Mesh.ARRAY_VERTEX] = verts
		arrays[Mesh.ARRAY_INDEX] = indices
		if attrs.has("NORMAL"):
			var nrm = _accessor(int(attrs.NORMAL))
			if nrm == null:
				return null
			var normals = PoolVector3Array()
			for i in range(vertex_count):
				normals.append(Vector3(nrm[3 * i], nrm[3 * i + 1], nrm[3 * i + 2]))
			arrays[Mesh.ARRAY_NORMAL] = normals
		if attrs.has("TEXCOORD_0"):
			var tc = _accessor(int(attrs.TEXCOORD_0))
			if tc == null:
				return null
			var uvs = PoolVector2Array()
			for i in range(vertex_count):
				uvs.append(Vector2(tc[2 * i], tc[2 * i + 1]))
			arrays[Mesh.ARRAY_TEX_UV] = uvs
		mesh.add_surface_from_arrays(Mesh.PRIMITIVE_TRIANGLES, arrays)
		var surface = mesh.get_surface_count() - 1
		if not attrs.has("NORMAL"):
			var st = SurfaceTool.new()
			st.create_from(mesh, surface)
			st.deindex()
			st.generate_normals()
			mesh.surface_remove(surface)
			st.commit(mesh)
		var mat = _material(int(prim.get("material", -1)), unshaded)
		if mat == null:
			return null
		mesh.surface_set_material(surface, mat)
	return mesh


# Accessor `index` as a flat Array of numbers (normalised integers mapped
# to 0..1 / -1..1), or null.
func _accessor(index):
	var acc = _gltf.accessors[index]
	if acc.has("sparse"):
		error = "accessor %d is sparse (not supported by this reader)" % index
		return null
	var ctype = int(acc.componentType)
	var comps = COMPONENTS.get(acc.type, 0)
	var count = int(acc.count)
	if comps == 0 or not COMPONENT_SIZE.has(ctype):
		error = "accessor %d: type %s / componentType %d not read" % [index, acc.type, ctype]
		return null
	var view = _gltf.bufferViews[int(acc.bufferView)]
	if int(view.get("buffer", 0)) != 0 or _gltf.buffers[0].has("uri"):
		error = "accessor %d: only the .glb's own binary chunk is read" % index
		return null
	var size = COMPONENT_SIZE[ctype]
	var stride = int(view.get("byteStride", comps * size))
	var base = int(view.get("byteOffset", 0)) + int(acc.get("byteOffset", 0))
	if base + (count - 1) * stride + comps * size > _bin.size():
		error = "accessor %d runs past the binary chunk" % index
		return null
	var normalized = acc.get("normalized", false)
	var out = []
	out.resize(count * comps)
	for i in range(count):
		_buf.seek(base + i * stride)
		for c in range(comps):
			var v
			match ctype:
				5126:
					v = _buf.get_float()
				5125:
					v = _buf.get_u32()
				5123:
					v = _buf.get_u16()
					if normalized:
						v = v / 65535.0
				5122:
					v = _buf.get_16()
					if normalized:
						v = max(v / 32767.0, -1.0)
				5121:
					v = _buf.get_u8()
					if normalized:
						v = v / 255.0
				5120:
					v = _buf.get_8()
					if normalized:
						v = max(v / 127.0, -1.0)
			out[i * comps + c] = v
	return out


static func _linear_to_srgb(x):
	return x * 12.92 if x <= 0.0031308 else 1.055 * pow(x, 1.0 / 2.4) - 0.055


func _material(index, unshaded):
	var key = "%d/%s" % [index, unshaded]
	if _materials.has(key):
		return _materials[key]
	var mat = SpatialMaterial.new()
	mat.flags_unshaded = unshaded
	if index >= 0:
		var m = _gltf.materials[index]
		var pbr = m.get("pbrMetallicRoughness", {})
		var f = pbr.get("baseColorFactor", [1, 1, 1, 1])
		mat.albedo_color = Color(_linear_to_srgb(f[0]), _linear_to_srgb(f[1]), _linear_to_srgb(f[2]), f[3])
		mat.metallic = pbr.get("metallicFactor", 1.0)
		mat.roughness = pbr.get("roughnessFactor", 1.0)
		if pbr.has("baseColorTexture"):
			var tex = _texture(int(pbr.baseColorTexture.index))
			if tex == null:
				return null
			mat.albedo_texture = tex
		match m.get("alphaMode", "OPAQUE"):
			"MASK":
				mat.params_use_alpha_scissor = true
				mat.params_alpha_scissor_threshold = m.get("alphaCutoff", 0.5)
			"BLEND":
				# Baked as a cutout at 0.5 (common/manifest_format.md): drawn so too.
				mat.params_use_alpha_scissor = true
				mat.params_alpha_scissor_threshold = 0.5
		if m.get("doubleSided", false):
			mat.params_cull_mode = SpatialMaterial.CULL_DISABLED
	_materials[key] = mat
	return mat


func _texture(index):
	if _textures.has(index):
		return _textures[index]
	var source = int(_gltf.textures[index].get("source", -1))
	if source < 0:
		error = "texture %d has no PNG or JPEG source" % index
		return null
	var image_def = _gltf.images[source]
	if not image_def.has("bufferView"):
		error = "image %d is not embedded in the .glb" % source
		return null
	var view = _gltf.bufferViews[int(image_def.bufferView)]
	var start = int(view.get("byteOffset", 0))
	var data = _bin.subarray(start, start + int(view.byteLength) - 1)
	var img = Image.new()
	var err = img.load_jpg_from_buffer(data) if image_def.get("mimeType", "") == "image/jpeg" else img.load_png_from_buffer(data)
	if err != OK:
		error = "image %d does not decode (error %d)" % [source, err]
		return null
	img.generate_mipmaps()
	var tex = ImageTexture.new()
	tex.create_from_image(img, Texture.FLAGS_DEFAULT)
	_textures[index] = tex
	return tex

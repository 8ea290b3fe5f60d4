# Reads a published release (client/delivery/release_format.md) over HTTP
# from one or more mirrors: the channel file, the catalog it names and the
# files of one asset, each verified against its SHA-256 (HashingContext)
# and size before anything uses it.
#
# Sources and order: for the immutable files (catalog, blobs) the cache
# under `cache_dir`, then each mirror in turn; for the channel file (the one
# that changes) each mirror, then the last copy read (offline use). A mirror
# is left for the next at a failed request, an HTTP status other than 200,
# a timeout, a size other than the catalog's or a digest mismatch (an HTML
# error page served with 200 is a mismatch). Nothing unverified is returned
# or cached; a cached file is verified again when read and dropped if it no
# longer matches. Two loads that need one digest share one download.
#
# Use (the client must be in the scene tree; every call is a coroutine):
#   var client = preload("res://addons/impostor/release_client.gd").new()
#   client.mirrors = ["https://cdn.example.com/impostors", "https://backup.example.com"]
#   client.channel = "nightly"
#   add_child(client)
#   var loaded = yield(client.load_asset("trees/oak"), "completed")
#   if not loaded.ok: push_error(loaded.error)
# then ImpostorAsset.build(loaded) (impostor_asset.gd) makes textures.
# Main thread only (HTTPRequest's signals arrive there).
extends Node

# Emitted when the download of a digest ends, well or not (request
# collapsing: waiters read the cache then).
signal digest_settled(sha256)

const CHANNEL_SCHEMA = "impostor-channel"
const CATALOG_SCHEMA = "impostor-catalog"
const SCHEMA_VERSION = 1  # the newest channel / catalog schema_version read

# Mirror base URLs (the directory that holds v1/), tried in this order.
var mirrors = []
# The channel to read: [A-Za-z0-9][A-Za-z0-9._-]{0,63}.
var channel = "nightly"
# Verified catalogs and blobs (by digest, as on a mirror) and the last
# channel file read. Any writable path: user://, or an absolute directory.
var cache_dir = "user://impostor_cache"
# A request that has not completed in this many seconds fails (the next
# mirror is tried). 0 = no limit.
var timeout_seconds = 15.0

var _inflight = {}  # sha256 -> true while one download runs


# Resolves `asset_name` through the channel's catalog and fetches every file
# of the asset. Coroutine; its "completed" result is a Dictionary:
#   ok: bool; error: String (empty when ok): names the file, the digest it
#     should have and every source's failure, e.g. "albedo_alpha.png (sha256
#     X): no mirror served it verified: albedo_alpha.png: SHA-256 mismatch
#     from URL: expected X, got Y";
#   name, channel, catalog_sha256, channel_source ("network" or "cache");
#   entry: the catalog's entry for the asset (cache_key, product, layout,
#     frames, resolution, manifest, files);
#   files: {file name: PoolByteArray}, every file verified;
#   report: [{name, semantic, sha256, size_bytes, verified, source
#     ("cache" or "network"), url}] in the catalog's order.
func load_asset(asset_name):
	yield(get_tree(), "idle_frame")
	var out = {"ok": false, "error": "", "name": asset_name, "channel": channel, "catalog_sha256": "",
			"channel_source": "", "entry": {}, "files": {}, "report": []}
	if not is_valid_asset_name(asset_name):
		out.error = "asset name \"%s\": want 1..200 characters of [A-Za-z0-9._/-], no empty, . or .. segment" % asset_name
		return out
	if not is_valid_channel_name(channel):
		out.error = "channel name \"%s\": want [A-Za-z0-9][A-Za-z0-9._-]{0,63}" % channel
		return out
	var ch = yield(_fetch_channel(), "completed")
	if not ch.ok:
		out.error = ch.error
		return out
	out.channel_source = ch.source
	var catalog_digest = ch.channel.catalog
	out.catalog_sha256 = catalog_digest.sha256
	var cat_bytes = yield(_fetch_verified("catalogs", "catalog of channel " + channel, catalog_digest.sha256,
			int(catalog_digest.size_bytes)), "completed")
	if not cat_bytes.ok:
		out.error = cat_bytes.error
		return out
	var cat = parse_catalog(cat_bytes.body)
	if cat.error != "":
		out.error = "catalog %s: %s" % [catalog_digest.sha256, cat.error]
		return out
	var assets = cat.catalog.assets
	if not assets.has(asset_name):
		var names = assets.keys()
		names.sort()
		out.error = "asset \"%s\" is not in channel %s (catalog %s lists %d: %s)" % [
				asset_name, channel, catalog_digest.sha256, names.size(), PoolStringArray(names).join(", ")]
		return out
	var entry = assets[asset_name]
	var problem = _check_entry(entry)
	if problem != "":
		out.error = "asset \"%s\" in catalog %s: %s" % [asset_name, catalog_digest.sha256, problem]
		return out
	out.entry = entry
	for f in entry.files:
		var got = yield(_fetch_verified("blobs", f.name, f.sha256, int(f.size_bytes)), "completed")
		if not got.ok:
			out.error = got.error
			out.files = {}
			return out
		out.files[f.name] = got.body
		out.report.append({"name": f.name, "semantic": f.get("semantic", ""), "sha256": f.sha256,
				"size_bytes": int(f.size_bytes), "verified": true, "source": got.source, "url": got.url})
	out.ok = true
	return out


# Lowercase hex SHA-256 of `bytes`.
static func sha256_hex(bytes):
	var ctx = HashingContext.new()
	ctx.start(HashingContext.HASH_SHA256)
	if bytes.size() > 0:
		ctx.update(bytes)
	return ctx.finish().hex_encode()


# (Plain loops, not RegEx: freeing a RegEx logs an engine error in 3.2.3.)
const ALNUM = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789"


static func _only(s, allowed):
	for c in s:
		if allowed.find(c) < 0:
			return false
	return true


static func is_valid_channel_name(name):
	return name is String and name.length() >= 1 and name.length() <= 64 and ALNUM.find(name[0]) >= 0 \
			and _only(name, ALNUM + "._-")


static func is_valid_asset_name(name):
	if not name is String or name.length() < 1 or name.length() > 200 or not _only(name, ALNUM + "._/-"):
		return false
	for segment in name.split("/"):
		if segment == "" or segment == "." or segment == "..":
			return false
	return true


static func _is_sha256(s):
	return s is String and s.length() == 64 and _only(s, "0123456789abcdef")


# {channel: Dictionary, error: String} from a channel file's bytes.
static func parse_channel(bytes):
	var parsed = JSON.parse(bytes.get_string_from_utf8())
	if parsed.error != OK or not parsed.result is Dictionary:
		return {"channel": {}, "error": "not a JSON object"}
	var c = parsed.result
	if c.get("schema") != CHANNEL_SCHEMA:
		return {"channel": {}, "error": "schema %s, want %s" % [str(c.get("schema")), CHANNEL_SCHEMA]}
	var version = c.get("schema_version")
	if not (version is float or version is int) or int(version) < 1:
		return {"channel": {}, "error": "schema_version %s is not a version" % str(version)}
	if int(version) > SCHEMA_VERSION:
		return {"channel": {}, "error": "schema_version %d is newer than the %d this add-on reads" % [int(version), SCHEMA_VERSION]}
	var catalog = c.get("catalog")
	if not catalog is Dictionary or not _is_sha256(catalog.get("sha256")) or not (catalog.get("size_bytes") is float):
		return {"channel": {}, "error": "no catalog {sha256, size_bytes}"}
	return {"channel": c, "error": ""}


# {catalog: Dictionary, error: String} from a catalog's bytes.
static func parse_catalog(bytes):
	var parsed = JSON.parse(bytes.get_string_from_utf8())
	if parsed.error != OK or not parsed.result is Dictionary:
		return {"catalog": {}, "error": "not a JSON object"}
	var c = parsed.result
	if c.get("schema") != CATALOG_SCHEMA:
		return {"catalog": {}, "error": "schema %s, want %s" % [str(c.get("schema")), CATALOG_SCHEMA]}
	var version = c.get("schema_version")
	if not (version is float) or int(version) < 1:
		return {"catalog": {}, "error": "schema_version %s is not a version" % str(version)}
	if int(version) > SCHEMA_VERSION:
		return {"catalog": {}, "error": "schema_version %d is newer than the %d this add-on reads" % [int(version), SCHEMA_VERSION]}
	if not c.get("assets") is Dictionary:
		return {"catalog": {}, "error": "no assets object"}
	return {"catalog": c, "error": ""}


# "" when the catalog entry lists files this client can fetch safely.
static func _check_entry(entry):
	if not entry is Dictionary or not entry.get("files") is Array or entry.files.empty():
		return "no files listed"
	for f in entry.files:
		if not f is Dictionary:
			return "a file entry is not an object"
		var name = f.get("name")
		if not name is String or name == "" or name == "." or name == ".." or "/" in name or "\\" in name:
			return "file name %s is not a plain file name" % str(name)
		if not _is_sha256(f.get("sha256")):
			return "%s: sha256 %s is not 64 lowercase hex digits" % [name, str(f.get("sha256"))]
		if not (f.get("size_bytes") is float) or f.size_bytes < 0:
			return "%s: no size_bytes" % name
	return ""


static func _release_path(kind, sha256):
	return "v1/%s/sha256/%s/%s" % [kind, sha256.substr(0, 2), sha256]


static func _join(base, rel):
	return base.rstrip("/") + "/" + rel


# The channel file from the first mirror that serves a valid one, else the
# last one read (offline). Coroutine: {ok, channel, source, error}.
func _fetch_channel():
	yield(get_tree(), "idle_frame")
	var rel = "v1/channels/%s.json" % channel
	var failures = []
	for m in mirrors:
		var url = _join(m, rel)
		var r = yield(_http_get(url, ["Cache-Control: no-cache"]), "completed")
		if not r.ok:
			failures.append("%s: %s" % [url, r.error])
			continue
		var parsed = parse_channel(r.body)
		if parsed.error != "":
			failures.append("%s: %s" % [url, parsed.error])
			continue
		_write_cache(rel, r.body)
		return {"ok": true, "channel": parsed.channel, "source": "network", "error": ""}
	var cached = _read_cache(rel)
	if cached != null:
		var parsed = parse_channel(cached)
		if parsed.error == "":
			if not failures.empty():
				print("impostor: channel %s from the cache (offline): %s" % [channel, PoolStringArray(failures).join("; ")])
			return {"ok": true, "channel": parsed.channel, "source": "cache", "error": ""}
	var why = PoolStringArray(failures).join("; ") if not failures.empty() else "no mirror is set"
	return {"ok": false, "channel": {}, "source": "",
			"error": "channel %s: no mirror served it and none is cached: %s" % [channel, why]}


# The bytes whose SHA-256 is `sha256` (and size `size_bytes`): from the
# cache, else from the first mirror that serves them intact. `label` names
# the file in errors. Coroutine: {ok, body, source, url, error}.
func _fetch_verified(kind, label, sha256, size_bytes):
	yield(get_tree(), "idle_frame")
	while _inflight.has(sha256):
		yield(self, "digest_settled")
	var rel = _release_path(kind, sha256)
	var cached = _read_cache(rel)
	if cached != null:
		if cached.size() == size_bytes and sha256_hex(cached) == sha256:
			return {"ok": true, "body": cached, "source": "cache", "url": cache_dir.plus_file(rel), "error": ""}
		Directory.new().remove(cache_dir.plus_file(rel))  # rotted on disk: fetched again
	_inflight[sha256] = true
	var failures = []
	var result = null
	for m in mirrors:
		var url = _join(m, rel)
		var r = yield(_http_get(url, []), "completed")
		if not r.ok:
			failures.append("%s: %s" % [url, r.error])
			continue
		if r.body.size() != size_bytes:
			failures.append("%s: %s: %d bytes, the catalog says %d" % [label, url, r.body.size(), size_bytes])
			continue
		var actual = sha256_hex(r.body)
		if actual != sha256:
			var mismatch = "%s: SHA-256 mismatch from %s: expected %s, got %s" % [label, url, sha256, actual]
			push_warning("impostor: " + mismatch)
			failures.append(mismatch)
			continue
		_write_cache(rel, r.body)
		result = {"ok": true, "body": r.body, "source": "network", "url": url, "error": ""}
		break
	_inflight.erase(sha256)
	emit_signal("digest_settled", sha256)
	if result != null:
		return result
	var why = PoolStringArray(failures).join("; ") if not failures.empty() else "no mirror is set"
	return {"ok": false, "body": PoolByteArray(), "source": "", "url": "",
			"error": "%s (sha256 %s): no mirror served it verified: %s" % [label, sha256, why]}


# GET `url`. Coroutine: {ok, body, error}; ok only for a completed 200.
func _http_get(url, headers):
	var req = HTTPRequest.new()
	req.use_threads = false
	req.download_chunk_size = 65536
	req.timeout = timeout_seconds
	add_child(req)
	var err = req.request(url, PoolStringArray(headers))
	if err != OK:
		req.queue_free()
		yield(get_tree(), "idle_frame")
		return {"ok": false, "body": PoolByteArray(), "error": "request not sent (error %d)" % err}
	var r = yield(req, "request_completed")  # result, response_code, headers, body
	req.queue_free()
	if r[0] != HTTPRequest.RESULT_SUCCESS:
		return {"ok": false, "body": PoolByteArray(), "error": _result_text(r[0])}
	if r[1] != 200:
		return {"ok": false, "body": PoolByteArray(), "error": "HTTP %d" % r[1]}
	return {"ok": true, "body": r[3], "error": ""}


static func _result_text(result):
	match result:
		HTTPRequest.RESULT_CANT_CONNECT:
			return "cannot connect"
		HTTPRequest.RESULT_CANT_RESOLVE:
			return "cannot resolve the host"
		HTTPRequest.RESULT_CONNECTION_ERROR:
			return "connection error"
		HTTPRequest.RESULT_SSL_HANDSHAKE_ERROR:
			return "TLS handshake failed"
		HTTPRequest.RESULT_NO_RESPONSE:
			return "no response"
		HTTPRequest.RESULT_BODY_SIZE_LIMIT_EXCEEDED:
			return "body too large"
		HTTPRequest.RESULT_REQUEST_FAILED:
			return "request failed"
		HTTPRequest.RESULT_REDIRECT_LIMIT_REACHED:
			return "too many redirects"
		HTTPRequest.RESULT_TIMEOUT:
			return "timed out"
	return "request failed (result %d)" % result


# The cached bytes at `rel`, or null.
func _read_cache(rel):
	var f = File.new()
	var path = cache_dir.plus_file(rel)
	if not f.file_exists(path) or f.open(path, File.READ) != OK:
		return null
	var bytes = f.get_buffer(f.get_len())
	f.close()
	return bytes


# Stores verified bytes at `rel`: a temporary file renamed into place, so a
# reader never sees a partial file. A cache that cannot be written is
# reported and skipped (the bytes are still used).
func _write_cache(rel, bytes):
	var path = cache_dir.plus_file(rel)
	var dir = Directory.new()
	if dir.make_dir_recursive(path.get_base_dir()) != OK:
		push_warning("impostor: cannot create the cache directory " + path.get_base_dir())
		return
	var tmp = "%s.tmp%d" % [path, OS.get_process_id()]
	var f = File.new()
	if f.open(tmp, File.WRITE) != OK:
		push_warning("impostor: cannot write the cache file " + tmp)
		return
	f.store_buffer(bytes)
	f.close()
	if dir.file_exists(path):
		dir.remove(path)
	if dir.rename(tmp, path) != OK:
		push_warning("impostor: cannot rename %s to %s" % [tmp, path])
		dir.remove(tmp)

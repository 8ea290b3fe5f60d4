#!/usr/bin/env python3
"""Packs built binaries with their shared libraries for another x86-64 Linux
host, so the worker's GPU suites and benches can run on a GPU machine that
has a Vulkan driver but none of Debian's packages (tools/gpu_check/README.md).

  python3 tools/gpu_check/pack.py OUT_DIR BINARY...

Writes OUT_DIR/bin (the binaries, stripped) and OUT_DIR/lib (every library
they need but the C library itself). OpenImageIO links plugin libraries that
a bake never opens (ffmpeg, OpenCV, DICOM, OpenVDB, libraw, libheif: over
250 MB with their own needs); each is replaced by a stub that exports the
symbols the other libraries import from it. OpenImageIO is linked with
BIND_NOW, so every symbol must resolve at load; the stubs' functions return
a pointer to zeros, which is what the plugins' static initialisers and
version queries then see.
"""
import os
import re
import shutil
import subprocess
import sys

STUBBED = {
    "libopencv_core.so.406", "libopencv_imgproc.so.406", "libopencv_videoio.so.406",
    "libdcmimage.so.17", "libdcmimgle.so.17", "libdcmdata.so.17", "liboflog.so.17", "libofstd.so.17",
    "libavcodec.so.59", "libavformat.so.59", "libavutil.so.57", "libswscale.so.6", "libheif.so.1",
    "libopenvdb.so.10.0", "libraw_r.so.20",
}
# The C library and the loader come from the host.
HOST = re.compile(r"^(libc\.so|libm\.so|libpthread|libdl\.so|librt\.so|ld-linux|linux-vdso)")


def run(*args):
    return subprocess.run(args, capture_output=True, text=True, check=True).stdout


def library_paths():
    paths = {}
    for line in run("ldconfig", "-p").splitlines()[1:]:
        m = re.match(r"\s*(\S+) \(libc6,x86-64[^)]*\) => (\S+)", line)
        if m and m.group(1) not in paths:
            paths[m.group(1)] = m.group(2)
    return paths


def needed(path):
    return re.findall(r"NEEDED\s+(\S+)", run("objdump", "-p", path))


def dynamic_symbols(path):
    """(name, version or None, type, size, defined) of each dynamic symbol."""
    out = []
    for line in run("readelf", "--dyn-syms", "-W", path).splitlines():
        f = line.split()
        if len(f) < 8 or not f[0].rstrip(":").isdigit() or f[6] == "ABS":
            continue
        name, version = f[7], None
        if "@@" in name:
            name, version = name.split("@@")
        elif "@" in name:
            name, version = name.split("@")[0], ""  # an old version: never stubbed
        size = int(f[2], 0) if f[2].startswith("0x") else int(f[2])
        out.append((name, version, f[3], size, f[6] != "UND"))
    return out


def write_stub(real, soname, wanted, lib_dir, scratch):
    asm = [".section .rodata\nstub_zeros: .zero 64\n"]
    versions = {}
    for name, version, kind, size, defined in dynamic_symbols(real):
        if not defined or version == "" or name not in wanted:
            continue
        if version:
            versions.setdefault(version, []).append(name)
        q = '"%s"' % name
        if kind in ("FUNC", "IFUNC", "NOTYPE"):
            asm.append(".text\n.globl %s\n.type %s,@function\n%s:\n lea stub_zeros(%%rip),%%rax\n ret\n" % (q, q, q))
        elif kind == "TLS":
            asm.append('.section .tbss,"awT",@nobits\n.globl %s\n.type %s,@object\n.size %s,%d\n%s:\n .zero %d\n'
                       % (q, q, q, max(size, 1), q, max(size, 1)))
        else:
            asm.append(".bss\n.globl %s\n.type %s,@object\n.size %s,%d\n%s:\n .zero %d\n"
                       % (q, q, q, max(size, 1), q, max(size, 1)))
    source = os.path.join(scratch, soname + ".s")
    with open(source, "w") as f:
        f.write("".join(asm))
    cmd = ["gcc", "-shared", "-nostdlib", "-o", os.path.join(lib_dir, soname), source, "-Wl,-soname," + soname]
    if versions:
        script = os.path.join(scratch, soname + ".map")
        with open(script, "w") as f:
            for version, names in versions.items():
                f.write("%s { global:\n%s\n};\n" % (version, "\n".join(n + ";" for n in names)))
        cmd.append("-Wl,--version-script=" + script)
    subprocess.run(cmd, check=True)


def main():
    if len(sys.argv) < 3:
        sys.exit("usage: pack.py OUT_DIR BINARY...")
    out, binaries = sys.argv[1], sys.argv[2:]
    lib_dir, bin_dir, scratch = (os.path.join(out, d) for d in ("lib", "bin", "stub-sources"))
    for d in (lib_dir, bin_dir, scratch):
        os.makedirs(d, exist_ok=True)
    paths = library_paths()
    seen, stubs, queue = set(), [], [n for b in binaries for n in needed(b)]
    while queue:
        name = queue.pop()
        if name in seen or HOST.match(name):
            continue
        seen.add(name)
        if name in STUBBED:
            stubs.append(name)
            continue
        if name not in paths:
            sys.exit("pack.py: %s is needed but not installed here" % name)
        shutil.copy(os.path.realpath(paths[name]), os.path.join(lib_dir, name))
        queue += needed(paths[name])
    # The symbols anything kept imports: all a stub must define.
    wanted = set()
    for path in [os.path.join(lib_dir, n) for n in os.listdir(lib_dir)] + binaries:
        wanted.update(name for name, _, _, _, defined in dynamic_symbols(path) if not defined)
    for name in stubs:
        write_stub(os.path.realpath(paths[name]), name, wanted, lib_dir, scratch)
    shutil.rmtree(scratch)
    for b in binaries:
        target = os.path.join(bin_dir, os.path.basename(b))
        shutil.copy(b, target)
        subprocess.run(["strip", target], check=True)
    print("pack.py: %d binaries, %d libraries, %d of them stubs" % (len(binaries), len(seen), len(stubs)))


if __name__ == "__main__":
    main()

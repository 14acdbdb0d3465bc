#!/usr/bin/env python3
"""Package the Blender add-on with the compiled prism binary inside.

    python3 blender_addon/package.py [--out target/addon] [--no-build] [--binary PATH]
                                     [--avx2-binary PATH]

Builds a portable binary (the architecture's baseline instruction set, in target/portable) unless
--no-build is given.

Writes two installable zips (the binary goes to prism/bin/prism, where the add-on looks first; on
x86-64 an AVX2 build goes beside it as bin/prism-x86-64-v3, which the portable binary hands over to
on CPUs that have AVX2):
  target/addon/prism-<version>-addon.zip      legacy add-on (Blender 3.4+): one top-level folder prism/
                                      (Preferences > Add-ons > Install, or addon_install(filepath=...))
  target/addon/prism-<version>-extension.zip  extension (Blender 4.2+): blender_manifest.toml at the root
                                      (Get Extensions > Install from Disk, or
                                      extensions.package_install_files(filepath=..., repo='user_default'))
Prints the two paths, one per line.
"""

import argparse
import os
import platform
import re
import shutil
import stat
import subprocess
import sys
import zipfile

HERE = os.path.dirname(os.path.abspath(__file__))
REPO = os.path.dirname(HERE)
SRC = os.path.join(HERE, "prism")


def version():
    with open(os.path.join(SRC, "blender_manifest.toml")) as f:
        return re.search(r'^version\s*=\s*"([^"]+)"', f.read(), re.M).group(1)


def addon_files():
    for root, dirs, files in os.walk(SRC):
        dirs[:] = sorted(d for d in dirs if d not in {"__pycache__", "bin"})
        for name in sorted(files):
            if name.endswith((".pyc", ".pyo")):
                continue
            path = os.path.join(root, name)
            yield path, os.path.relpath(path, SRC)


def write_zip(path, prefix, binaries):
    """binaries: {name in bin/: file}."""
    with zipfile.ZipFile(path, "w", zipfile.ZIP_DEFLATED) as z:
        for src, rel in addon_files():
            z.write(src, prefix + rel)
        for name, binary in sorted(binaries.items()):
            info = zipfile.ZipInfo(prefix + "bin/" + name)
            info.external_attr = (stat.S_IFREG | 0o755) << 16
            info.compress_type = zipfile.ZIP_DEFLATED
            with open(binary, "rb") as f:
                z.writestr(info, f.read())


def stripped_copy(binary, out_dir, name="prism"):
    """The binary without debug symbols (a third of the size), if `strip` is available."""
    strip = shutil.which("strip")
    if strip is None:
        return binary
    dst = os.path.join(out_dir, ".%s.stripped" % name)
    shutil.copyfile(binary, dst)
    if subprocess.run([strip, dst]).returncode != 0:
        return binary
    return dst


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--out", default=os.path.join(REPO, "target", "addon"))
    ap.add_argument("--no-build", action="store_true",
                    help="package an existing binary as it is (--binary; the default, target/release/prism, "
                    "is built for this machine's instruction set: the zip then runs only on CPUs like it)")
    ap.add_argument("--binary", help="the binary to package (default: the portable build, "
                    "target/portable/release/prism; with --no-build: target/release/prism)")
    ap.add_argument("--avx2-binary", help="with --no-build: an x86-64-v3 build to bundle as "
                    "bin/prism-x86-64-v3")
    args = ap.parse_args()
    if args.binary is None:
        sub = "release" if args.no_build else os.path.join("portable", "release")
        args.binary = os.path.join(REPO, "target", sub, "prism")
    extra = {}
    if not args.no_build:
        # A zip is installed on other machines: build for the architecture's baseline, not for
        # this machine's instruction set (.cargo/config.toml's target-cpu=native, which a set
        # RUSTFLAGS replaces), in its own target directory so the native build stays. On x86-64
        # also an x86-64-v3 (AVX2, FMA) build, which the portable one hands over to on CPUs that
        # have it (src/main.rs, hand_over_to_avx2_build).
        builds = [("portable", "")]
        if platform.machine().lower() in ("x86_64", "amd64"):
            builds.append(("portable-v3", "-C target-cpu=x86-64-v3"))
        for target_dir, flags in builds:
            env = dict(os.environ, RUSTFLAGS=flags)
            subprocess.run(["cargo", "build", "--release", "-q", "--target-dir",
                            os.path.join(REPO, "target", target_dir)], cwd=REPO, check=True, env=env)
        if len(builds) > 1:
            extra["prism-x86-64-v3"] = os.path.join(REPO, "target", "portable-v3", "release", "prism")
    elif args.avx2_binary:
        extra["prism-x86-64-v3"] = args.avx2_binary
    if not os.path.isfile(args.binary):
        sys.exit("no binary at %s (run cargo build --release)" % args.binary)
    os.makedirs(args.out, exist_ok=True)
    v = version()
    legacy = os.path.join(args.out, "prism-%s-addon.zip" % v)
    ext = os.path.join(args.out, "prism-%s-extension.zip" % v)
    sources = dict(extra, prism=args.binary)
    binaries = {name: stripped_copy(path, args.out, name) for name, path in sources.items()}
    write_zip(legacy, "prism/", binaries)
    write_zip(ext, "", binaries)
    for name, path in binaries.items():
        if path != sources[name]:
            os.remove(path)
    print(legacy)
    print(ext)


if __name__ == "__main__":
    main()

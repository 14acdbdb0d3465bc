#!/usr/bin/env python3
"""Package the Blender add-on with the compiled prism binary inside.

    python3 blender_addon/package.py [--out target/addon] [--no-build] [--binary PATH]

Builds a portable binary (the architecture's baseline instruction set, in target/portable) unless
--no-build is given.

Writes two installable zips (the binary goes to prism/bin/prism, where the add-on looks first):
  target/addon/prism-<version>-addon.zip      legacy add-on (Blender 3.4+): one top-level folder prism/
                                      (Preferences > Add-ons > Install, or addon_install(filepath=...))
  target/addon/prism-<version>-extension.zip  extension (Blender 4.2+): blender_manifest.toml at the root
                                      (Get Extensions > Install from Disk, or
                                      extensions.package_install_files(filepath=..., repo='user_default'))
Prints the two paths, one per line.
"""

import argparse
import os
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


def write_zip(path, prefix, binary):
    with zipfile.ZipFile(path, "w", zipfile.ZIP_DEFLATED) as z:
        for src, rel in addon_files():
            z.write(src, prefix + rel)
        info = zipfile.ZipInfo(prefix + "bin/prism")
        info.external_attr = (stat.S_IFREG | 0o755) << 16
        info.compress_type = zipfile.ZIP_DEFLATED
        with open(binary, "rb") as f:
            z.writestr(info, f.read())


def stripped_copy(binary, out_dir):
    """The binary without debug symbols (a third of the size), if `strip` is available."""
    strip = shutil.which("strip")
    if strip is None:
        return binary
    dst = os.path.join(out_dir, ".prism.stripped")
    shutil.copyfile(binary, dst)
    if subprocess.run([strip, dst]).returncode != 0:
        return binary
    return dst


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--out", default=os.path.join(REPO, "target", "addon"))
    ap.add_argument("--no-build", action="store_true", help="use an existing binary (--binary)")
    ap.add_argument("--binary", help="the binary to package (default: the portable build, "
                    "target/portable/release/prism; with --no-build: target/release/prism)")
    args = ap.parse_args()
    if args.binary is None:
        sub = "release" if args.no_build else os.path.join("portable", "release")
        args.binary = os.path.join(REPO, "target", sub, "prism")
    if not args.no_build:
        # A zip is installed on other machines: build for the architecture's baseline, not for
        # this machine's instruction set (.cargo/config.toml's target-cpu=native, which a set
        # RUSTFLAGS replaces), in its own target directory so the native build stays.
        env = dict(os.environ, RUSTFLAGS="")
        subprocess.run(["cargo", "build", "--release", "-q", "--target-dir",
                        os.path.join(REPO, "target", "portable")], cwd=REPO, check=True, env=env)
    if not os.path.isfile(args.binary):
        sys.exit("no binary at %s (run cargo build --release)" % args.binary)
    os.makedirs(args.out, exist_ok=True)
    v = version()
    legacy = os.path.join(args.out, "prism-%s-addon.zip" % v)
    ext = os.path.join(args.out, "prism-%s-extension.zip" % v)
    binary = stripped_copy(args.binary, args.out)
    write_zip(legacy, "prism/", binary)
    write_zip(ext, "", binary)
    if binary != args.binary:
        os.remove(binary)
    print(legacy)
    print(ext)


if __name__ == "__main__":
    main()

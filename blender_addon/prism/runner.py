# SPDX-License-Identifier: MIT
"""Runs the prism binary: finds it, reads its JSON progress lines, stops it on cancel.

No bpy here except in find_binary (preferences), so the process logic stays testable.
"""

import json
import os
import queue
import shutil
import subprocess
import tempfile
import sys
import threading
import time

EXE = "prism.exe" if sys.platform == "win32" else "prism"
ADDON_DIR = os.path.dirname(os.path.realpath(__file__))


class RunnerError(Exception):
    pass


def candidate_binaries():
    """Where a binary is looked for when no path is set: bundled, PATH, the repository's build."""
    out = [("bundled", os.path.join(ADDON_DIR, "bin", EXE))]
    on_path = shutil.which("prism")
    if on_path:
        out.append(("PATH", on_path))
    repo = os.path.normpath(os.path.join(ADDON_DIR, "..", ".."))
    out.append(("repository", os.path.join(repo, "target", "release", EXE)))
    return out


if sys.platform == "win32":
    OIDN_NAMES = ("OpenImageDenoise.dll",)
elif sys.platform == "darwin":
    OIDN_NAMES = ("libOpenImageDenoise.2.dylib", "libOpenImageDenoise.dylib")
else:
    OIDN_NAMES = ("libOpenImageDenoise.so.2", "libOpenImageDenoise.so")


def oidn_search_dirs(binary_path, local_resources):
    """Where a running Blender keeps its Open Image Denoise library, from its executable and its
    version folder (`bpy.utils.resource_path('LOCAL')`, e.g. .../5.0): the bpy wheel's bpy/lib
    and official Linux builds' lib/ (both beside the version folder), Windows' blender.shared/,
    macOS' Contents/Resources/lib/."""
    dirs = []
    if local_resources:
        dirs.append(os.path.join(os.path.dirname(os.path.realpath(local_resources)), "lib"))
    if binary_path:
        d = os.path.dirname(os.path.realpath(binary_path))
        dirs += [
            os.path.join(d, "lib"),
            os.path.join(d, "blender.shared"),
            d,
            os.path.normpath(os.path.join(d, "..", "Resources", "lib")),
        ]
    unique = []
    for d in dirs:
        if d not in unique:
            unique.append(d)
    return unique


def find_oidn(dirs):
    """The first Open Image Denoise library in `dirs`, or None (e.g. Debian's Blender 3.4, and
    official 3.x builds, which link it statically: nothing the binary can load)."""
    for d in dirs:
        for name in OIDN_NAMES:
            path = os.path.join(d, name)
            if os.path.isfile(path):
                return path
    return None


def find_binary(configured=""):
    """The binary to run. An explicitly configured path must exist (no silent fallback)."""
    if configured:
        path = os.path.abspath(os.path.expanduser(configured))
        if os.path.isfile(path) and os.access(path, os.X_OK):
            return path
        raise RunnerError("binary not found at '%s' (set it in Preferences > Add-ons > Prism)" % configured)
    for where, path in candidate_binaries():
        if where == "bundled":
            # Zip installs (addon_install, extensions) drop the executable bit: of the binary,
            # and of the AVX2 build beside it that the binary hands over to (package.py).
            for p in (path, os.path.join(os.path.dirname(path), "prism-x86-64-v3")):
                if os.path.isfile(p) and not os.access(p, os.X_OK):
                    try:
                        os.chmod(p, os.stat(p).st_mode | 0o755)
                    except OSError:
                        pass
        if os.path.isfile(path) and os.access(path, os.X_OK):
            return path
    raise RunnerError(
        "binary not found (looked in %s); set its path in Preferences > Add-ons > Prism"
        % ", ".join(p for _w, p in candidate_binaries())
    )


EOF_EVENT = "_stderr_closed"
"""Pseudo-event poll() returns once the binary has closed its stderr (at exit)."""


class PrismProcess:
    """One `prism render` run. Iterate events with poll(); stop() ends it within a second."""

    def __init__(self, args, cwd=None):
        self.args = args
        try:
            self.proc = subprocess.Popen(
                args,
                stdin=subprocess.DEVNULL,
                stdout=subprocess.DEVNULL,
                stderr=subprocess.PIPE,
                cwd=cwd,
                start_new_session=(sys.platform != "win32"),
            )
        except OSError as e:
            raise RunnerError("cannot start %s: %s" % (args[0], e)) from e
        self.events = queue.Queue()
        self.finished = False
        self.error_lines = []
        self.other_lines = []
        self._reader = threading.Thread(target=self._read, daemon=True)
        self._reader.start()

    def _read(self):
        for raw in iter(self.proc.stderr.readline, b""):
            line = raw.decode("utf-8", "replace").strip()
            if not line:
                continue
            if line.startswith("{"):
                try:
                    self.events.put(json.loads(line))
                    continue
                except ValueError:
                    pass
            if line.startswith("prism: error:"):
                self.error_lines.append(line)
            else:
                self.other_lines.append(line)
        self.proc.stderr.close()
        # The binary has closed stderr (it is exiting): wake a waiting poll() at once instead of
        # letting it sit out its timeout.
        self.finished = True
        self.events.put({"event": EOF_EVENT})

    def poll(self, timeout=0.05):
        """Events received so far (waits up to `timeout` for the first)."""
        out = []
        try:
            out.append(self.events.get(timeout=timeout))
            while True:
                out.append(self.events.get_nowait())
        except queue.Empty:
            pass
        return out

    def running(self):
        return self.proc.poll() is None

    def wait(self, timeout=None):
        rc = self.proc.wait(timeout)
        self._reader.join(1.0)
        return rc

    def stop(self, grace=0.8):
        """SIGTERM (prism stops within a second), then SIGKILL; returns when the process is gone."""
        if self.proc.poll() is None:
            self.proc.terminate()
            try:
                self.proc.wait(grace)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait()
        self._reader.join(1.0)

    def error_message(self, rc):
        if self.error_lines:
            return self.error_lines[-1]
        tail = self.other_lines[-1] if self.other_lines else "no message"
        return "prism exited with code %d: %s" % (rc, tail)


def bvh_cache_dir():
    """Where the add-on lets the binary keep mesh BVHs between renders (`--bvh-cache`): the
    temporary folder, so the OS cleans it; the binary keeps it under 1 GiB."""
    return os.path.join(tempfile.gettempdir(), "prism-bvh-cache")


def render_args(binary, gltf, materials, output, preview, spp, width, height, max_depth, seed, threads,
                bvh_cache=None, denoise=False, oidn=None, denoise_previews=False, denoise_quality="HIGH",
                denoise_prefilter="ACCURATE", crop=None):
    args = [
        binary, "render", gltf,
        "--materials", materials,
        "-o", output,
        "--progress", "json",
        "--preview", preview,
        "--spp", str(spp),
        "--width", str(width),
        "--height", str(height),
        "--max-depth", str(max_depth),
        "--seed", str(seed),
        # Temporary files read at once: raw scanlines are the fastest to write and to read
        # (exr.py decodes RLE in Python: ~10 ms for 256x256, seconds for a 4K preview).
        "--exr-compression", "none",
    ]
    if threads > 0:
        args += ["--threads", str(threads)]
    if bvh_cache:
        args += ["--bvh-cache", bvh_cache]
    if denoise:
        args.append("--denoise")
        if oidn:
            args += ["--oidn", oidn]
        if denoise_previews:
            args.append("--denoise-previews")
        args += ["--denoise-quality", denoise_quality.lower(), "--denoise-prefilter", denoise_prefilter.lower()]
    if crop is not None:
        args += ["--crop", "%d,%d,%d,%d" % tuple(crop)]
    return args


def timed(fn):
    t0 = time.perf_counter()
    out = fn()
    return out, time.perf_counter() - t0

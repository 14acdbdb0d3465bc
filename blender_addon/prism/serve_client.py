# SPDX-License-Identifier: MIT
"""A client of `prism serve` (the protocol is documented in the renderer's src/serve.rs).

Independent of bpy, so tests can drive the renderer process directly. One thread reads the
process's stdout: events are kept in order (`events`), the newest frame of the current
generation in `frame`; `on_frame` is called from that thread when one arrives.
"""

import json
import os
import subprocess
import threading
import time

import numpy as np


class ServeError(Exception):
    pass


class Frame:
    """One frame: RGBA float32 pixels, shape (height, width, 4), bottom row first."""

    def __init__(self, generation, width, height, spp, pixels, received):
        self.generation = generation
        self.width = width
        self.height = height
        self.spp = spp
        self.pixels = pixels
        self.received = received


class ServeClient:
    def __init__(self, binary, threads=None, bvh_cache=None, on_frame=None, on_event=None):
        args = [binary, "serve"]
        if threads:
            args += ["--threads", str(int(threads))]
        if bvh_cache:
            args += ["--bvh-cache", bvh_cache]
        kwargs = {}
        if os.name == "posix":
            # Not in Blender's process group: Ctrl+C in a terminal does not kill it halfway
            # through a frame; Blender ends it (`close`).
            kwargs["start_new_session"] = True
        self.proc = subprocess.Popen(
            args, stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.PIPE, bufsize=0, **kwargs
        )
        self.on_frame = on_frame
        self.on_event = on_event
        self.lock = threading.Condition()
        self.events = []
        self.frame = None
        self.generation = 0
        # The newest generation whose render finished (or that had nothing to render), and
        # the commands sent that have no answer yet.
        self.done_generation = -1
        self.unanswered = 0
        self.stderr_tail = []
        self._reader = threading.Thread(target=self._read, daemon=True)
        self._reader.start()
        self._err_reader = threading.Thread(target=self._read_stderr, daemon=True)
        self._err_reader.start()
        self.wait_for(lambda e: e.get("event") == "ready", timeout=30)

    # -- reading
    def _read_exact(self, n):
        chunks = []
        while n > 0:
            c = self.proc.stdout.read(n)
            if not c:
                raise EOFError
            chunks.append(c)
            n -= len(c)
        return b"".join(chunks)

    def _read(self):
        f = self.proc.stdout
        try:
            while True:
                line = f.readline()
                if not line:
                    break
                try:
                    ev = json.loads(line)
                except ValueError:
                    continue
                ev["received"] = time.monotonic()
                if ev.get("event") == "frame":
                    data = self._read_exact(int(ev["bytes"]))
                    px = np.frombuffer(data, dtype="<f4").reshape(int(ev["height"]), int(ev["width"]), 4)
                    fr = Frame(ev["generation"], ev["width"], ev["height"], ev["spp"], px, ev["received"])
                    with self.lock:
                        # Frames of a generation before the last answered command are stale.
                        if fr.generation >= self.generation:
                            self.frame = fr
                        self.events.append(ev)
                        self.lock.notify_all()
                    if self.on_frame is not None:
                        self.on_frame(fr)
                    continue
                with self.lock:
                    kind = ev.get("event")
                    if kind in ("ok", "loaded", "error"):
                        self.unanswered = max(0, self.unanswered - 1)
                        if "generation" in ev:
                            self.generation = max(self.generation, int(ev["generation"]))
                    elif kind in ("done", "idle"):
                        self.done_generation = max(self.done_generation, int(ev["generation"]))
                    self.events.append(ev)
                    self.lock.notify_all()
                if self.on_event is not None:
                    self.on_event(ev)
        except (EOFError, OSError, ValueError):
            pass
        with self.lock:
            self.events.append({"event": "exit", "received": time.monotonic()})
            self.lock.notify_all()

    def _read_stderr(self):
        for line in self.proc.stderr:
            self.stderr_tail = (self.stderr_tail + [line.decode("utf-8", "replace").rstrip()])[-20:]

    def wait_for(self, predicate, timeout=60.0, since=0):
        """The first event at index >= `since` that `predicate` accepts; raises on timeout or
        when the process exits first."""
        deadline = time.monotonic() + timeout
        with self.lock:
            while True:
                for ev in self.events[since:]:
                    if predicate(ev):
                        return ev
                    if ev.get("event") == "exit":
                        raise ServeError("prism serve exited: %s" % " | ".join(self.stderr_tail[-3:]))
                left = deadline - time.monotonic()
                if left <= 0:
                    raise ServeError("prism serve: timed out waiting")
                self.lock.wait(left)

    # -- commands
    def send(self, cmd, **fields):
        """Sends a command; returns the index of the next event (for `wait_for(since=...)`)."""
        fields["cmd"] = cmd
        with self.lock:
            mark = len(self.events)
            if cmd != "quit":
                self.unanswered += 1
        try:
            self.proc.stdin.write((json.dumps(fields, separators=(",", ":")) + "\n").encode())
            self.proc.stdin.flush()
        except (BrokenPipeError, OSError) as e:
            raise ServeError("prism serve is not running: %s" % e)
        return mark

    def request(self, cmd, timeout=120.0, **fields):
        """Sends a command and waits for its answer (ok / loaded / error); raises on error."""
        mark = self.send(cmd, **fields)
        ev = self.wait_for(lambda e: e.get("event") in ("ok", "loaded", "error"), timeout=timeout, since=mark)
        if ev["event"] == "error":
            raise ServeError(ev.get("message", "error"))
        return ev

    def wait_frame(self, after, min_spp=0, timeout=60.0, full_size=None):
        """The first frame event at index >= `after` with at least `min_spp` samples (and, if
        given, the size (w, h)); returns (event, Frame-or-None for the newest frame)."""

        def ok(e):
            if e.get("event") != "frame" or e["spp"] < min_spp:
                return False
            return full_size is None or (e["width"], e["height"]) == tuple(full_size)

        ev = self.wait_for(ok, timeout=timeout, since=after)
        return ev, self.frame

    def finished(self):
        """Every command is answered and the render of the current generation is over."""
        with self.lock:
            return self.unanswered == 0 and self.done_generation >= self.generation

    def alive(self):
        return self.proc.poll() is None

    def close(self, timeout=5.0):
        """Ends the process (quit, then terminate, then kill); idempotent."""
        if self.proc.poll() is None:
            try:
                self.proc.stdin.write(b'{"cmd":"quit"}\n')
                self.proc.stdin.flush()
                self.proc.stdin.close()
            except (BrokenPipeError, OSError, ValueError):
                pass
            try:
                self.proc.wait(timeout)
            except subprocess.TimeoutExpired:
                self.proc.terminate()
                try:
                    self.proc.wait(2.0)
                except subprocess.TimeoutExpired:
                    self.proc.kill()
                    self.proc.wait()
        for s in (self.proc.stdout, self.proc.stderr):
            try:
                s.close()
            except (OSError, ValueError):
                pass

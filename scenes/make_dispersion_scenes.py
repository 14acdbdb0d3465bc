#!/usr/bin/env python3
"""Write Prism's dispersion scenes as single-file glTF 2.0 + material JSON sidecars.

Outputs (next to this script):
  prism/prism.gltf (+ .materials.json)
      A 55-degree glass prism on a grey floor. A far emissive strip shines through a slit in a
      black baffle onto the prism at minimum deviation (500 nm); the fanned-out spectrum falls on
      a white screen and, where the rays tilt down, on the floor. The glass is a deliberately
      exaggerated Cauchy glass (a = 1.3, b = 0.12: n = 1.89 at 450 nm, 1.58 at 650 nm, about
      six times the dispersion of SF11) so the band is wide compared with the beam's
      divergence and a path tracer, which finds this caustic only by BSDF-sampling from the
      screen into the light through the prism, shows clean colours at modest sample counts.
  rough_dispersive/rough_dispersive.gltf (+ .materials.json)
      Rough (roughness 0.2) dispersive glass -- a sphere and a slab -- on a coloured checker
      floor under a square area light, in a dim grey world. The glass is the sidecar's "SF11"
      preset (SCHOTT Sellmeier coefficients: n_d = 1.7847, V_d = 25.68).

Render: `prism render scenes/prism/prism.gltf` (the sidecar's "render" block has the defaults).
Stdlib only; the output is deterministic (same bytes on every run).

Conventions: 1 unit = 1 m, Y up, glTF camera looks down its local -Z. Geometry is written in
world space (identity nodes); triangles are counter-clockwise seen from their outside.
"""

import base64
import json
import math
import os
import struct

HERE = os.path.dirname(os.path.abspath(__file__))

FLOAT, UINT = 5126, 5125
ARRAY_BUFFER, ELEMENT_ARRAY_BUFFER = 34962, 34963


# ---------------------------------------------------------------- small vector helpers
def add(a, b):
    return tuple(x + y for x, y in zip(a, b))


def sub(a, b):
    return tuple(x - y for x, y in zip(a, b))


def mul(a, s):
    return tuple(x * s for x in a)


def dot(a, b):
    return sum(x * y for x, y in zip(a, b))


def cross(a, b):
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


def norm(a):
    return mul(a, 1.0 / math.sqrt(dot(a, a)))


def clean(v):
    return tuple(round(x, 9) + 0.0 for x in v)


# ---------------------------------------------------------------- glTF document builder
class Gltf:
    def __init__(self):
        self.blob = bytearray()
        self.views, self.accessors, self.meshes, self.nodes = [], [], [], []
        self.materials, self.cameras = [], []
        self.material_index = {}

    def _view(self, data, target):
        while len(self.blob) % 4:
            self.blob.append(0)
        self.views.append(
            {"buffer": 0, "byteOffset": len(self.blob), "byteLength": len(data), "target": target}
        )
        self.blob += data
        return len(self.views) - 1

    def _vec3(self, rows, bounds):
        data = b"".join(struct.pack("<3f", *r) for r in rows)
        acc = {"bufferView": self._view(data, ARRAY_BUFFER), "componentType": FLOAT,
               "count": len(rows), "type": "VEC3"}
        if bounds:
            f32 = [struct.unpack("<3f", struct.pack("<3f", *r)) for r in rows]
            acc["min"] = [min(r[i] for r in f32) for i in range(3)]
            acc["max"] = [max(r[i] for r in f32) for i in range(3)]
        self.accessors.append(acc)
        return len(self.accessors) - 1

    def _indices(self, idx):
        data = struct.pack("<%dI" % len(idx), *idx)
        self.accessors.append({"bufferView": self._view(data, ELEMENT_ARRAY_BUFFER),
                               "componentType": UINT, "count": len(idx), "type": "SCALAR"})
        return len(self.accessors) - 1

    def material(self, m):
        self.materials.append(m)
        self.material_index[m["name"]] = len(self.materials) - 1

    def mesh(self, name, parts):
        """parts: list of (Geo, material name). One node (identity transform) per mesh."""
        prims = []
        for geo, mat in parts:
            geo.check()
            prims.append({
                "attributes": {"POSITION": self._vec3(geo.pos, True),
                               "NORMAL": self._vec3(geo.nrm, False)},
                "indices": self._indices(geo.idx),
                "material": self.material_index[mat],
            })
        self.meshes.append({"name": name, "primitives": prims})
        self.nodes.append({"name": name, "mesh": len(self.meshes) - 1})

    def camera(self, name, eye, target, yfov, aspect):
        """Perspective camera at `eye` looking at `target`, +Y up."""
        f = norm(sub(target, eye))
        r = norm(cross(f, (0.0, 1.0, 0.0)))
        u = cross(r, f)
        # Columns of the rotation: local X = r, Y = u, Z = -f; matrix -> quaternion.
        m = [[r[0], u[0], -f[0]], [r[1], u[1], -f[1]], [r[2], u[2], -f[2]]]
        tr = m[0][0] + m[1][1] + m[2][2]
        if tr > 0:
            s = math.sqrt(tr + 1.0) * 2
            q = ((m[2][1] - m[1][2]) / s, (m[0][2] - m[2][0]) / s, (m[1][0] - m[0][1]) / s, 0.25 * s)
        elif m[0][0] > m[1][1] and m[0][0] > m[2][2]:
            s = math.sqrt(1.0 + m[0][0] - m[1][1] - m[2][2]) * 2
            q = (0.25 * s, (m[0][1] + m[1][0]) / s, (m[0][2] + m[2][0]) / s, (m[2][1] - m[1][2]) / s)
        elif m[1][1] > m[2][2]:
            s = math.sqrt(1.0 + m[1][1] - m[0][0] - m[2][2]) * 2
            q = ((m[0][1] + m[1][0]) / s, 0.25 * s, (m[1][2] + m[2][1]) / s, (m[0][2] - m[2][0]) / s)
        else:
            s = math.sqrt(1.0 + m[2][2] - m[0][0] - m[1][1]) * 2
            q = ((m[0][2] + m[2][0]) / s, (m[1][2] + m[2][1]) / s, 0.25 * s, (m[1][0] - m[0][1]) / s)
        self.cameras.append({"name": name + "Data", "type": "perspective",
                             "perspective": {"yfov": yfov, "aspectRatio": aspect, "znear": 0.01}})
        self.nodes.append({"name": name, "camera": len(self.cameras) - 1,
                           "translation": list(clean(eye)), "rotation": [round(x, 9) for x in q]})

    def write(self, path):
        doc = {
            "asset": {"version": "2.0", "generator": "scenes/make_dispersion_scenes.py"},
            "extensionsUsed": ["KHR_materials_emissive_strength", "KHR_materials_specular"],
            "scene": 0,
            "scenes": [{"nodes": list(range(len(self.nodes)))}],
            "nodes": self.nodes,
            "meshes": self.meshes,
            "materials": self.materials,
            "cameras": self.cameras,
            "accessors": self.accessors,
            "bufferViews": self.views,
            "buffers": [{"byteLength": len(self.blob), "uri": "data:application/octet-stream;base64,"
                         + base64.b64encode(bytes(self.blob)).decode("ascii")}],
        }
        os.makedirs(os.path.dirname(path), exist_ok=True)
        with open(path, "w") as f:
            json.dump(doc, f, indent=1)
            f.write("\n")


class Geo:
    """Triangles with per-vertex normals."""

    def __init__(self):
        self.pos, self.nrm, self.idx = [], [], []

    def tri(self, a, b, c, outward=None):
        """Flat triangle; wound so its normal points along `outward` when given."""
        n = cross(sub(b, a), sub(c, a))
        if outward is not None and dot(n, outward) < 0:
            b, c = c, b
            n = mul(n, -1.0)
        n = clean(norm(n))
        base = len(self.pos)
        self.pos += [clean(a), clean(b), clean(c)]
        self.nrm += [n, n, n]
        self.idx += [base, base + 1, base + 2]
        return self

    def rect(self, centre, u, v, hu, hv, facing):
        """Rectangle centre +- hu*u +- hv*v (u, v unit) facing `facing`."""
        p = lambda s, t: add(centre, add(mul(u, s * hu), mul(v, t * hv)))
        self.tri(p(-1, -1), p(1, -1), p(1, 1), facing)
        self.tri(p(-1, -1), p(1, 1), p(-1, 1), facing)
        return self

    def box(self, lo, hi):
        c = mul(add(lo, hi), 0.5)
        h = mul(sub(hi, lo), 0.5)
        for k in range(3):
            for s in (-1.0, 1.0):
                n = [0.0, 0.0, 0.0]
                n[k] = s
                u = [0.0, 0.0, 0.0]
                v = [0.0, 0.0, 0.0]
                u[(k + 1) % 3] = 1.0
                v[(k + 2) % 3] = 1.0
                self.rect(add(c, mul(tuple(n), h[k])), tuple(u), tuple(v),
                          h[(k + 1) % 3], h[(k + 2) % 3], tuple(n))
        return self

    def prism(self, tri_xz, y0, y1):
        """Triangle (three (x, z) points) extruded over y in [y0, y1], outward normals."""
        pts = [(x, 0.0, z) for x, z in tri_xz]
        cen = mul(add(add(pts[0], pts[1]), pts[2]), 1.0 / 3.0)
        lo = [add(p, (0.0, y0, 0.0)) for p in pts]
        hi = [add(p, (0.0, y1, 0.0)) for p in pts]
        self.tri(lo[0], lo[1], lo[2], (0.0, -1.0, 0.0))
        self.tri(hi[0], hi[1], hi[2], (0.0, 1.0, 0.0))
        for k in range(3):
            a, b = k, (k + 1) % 3
            out = sub(mul(add(pts[a], pts[b]), 0.5), cen)
            self.tri(lo[a], lo[b], hi[b], out)
            self.tri(lo[a], hi[b], hi[a], out)
        return self

    def sphere(self, centre, radius, segments=64, rings=32):
        """UV sphere with smooth normals."""
        base = len(self.pos)
        for i in range(rings + 1):
            th = math.pi * i / rings
            st, ct = (0.0 if i in (0, rings) else math.sin(th)), math.cos(th)
            for j in range(segments + 1):
                ph = 2.0 * math.pi * (j % segments) / segments
                n = clean((st * math.sin(ph), ct, st * math.cos(ph)))
                self.pos.append(clean(add(centre, mul(n, radius))))
                self.nrm.append(n)
        row = segments + 1
        for i in range(rings):
            for j in range(segments):
                a = base + i * row + j
                b, c = a + 1, a + row
                d = c + 1
                if i != 0:
                    self.idx += [a, c, b]
                if i != rings - 1:
                    self.idx += [b, c, d]
        return self

    def check(self):
        for t in range(0, len(self.idx), 3):
            a, b, c = (self.pos[i] for i in self.idx[t:t + 3])
            g = cross(sub(b, a), sub(c, a))
            n = add(add(self.nrm[self.idx[t]], self.nrm[self.idx[t + 1]]), self.nrm[self.idx[t + 2]])
            assert dot(g, g) > 1e-20, "degenerate triangle"
            assert dot(g, n) > 0, "triangle wound against its normals"


def diffuse(name, rgb):
    return {"name": name,
            "pbrMetallicRoughness": {"baseColorFactor": [rgb[0], rgb[1], rgb[2], 1.0],
                                     "metallicFactor": 0.0, "roughnessFactor": 1.0},
            "extensions": {"KHR_materials_specular": {"specularFactor": 0.0}}}


def emitter(name, strength):
    m = diffuse(name, (0.0, 0.0, 0.0))
    m["emissiveFactor"] = [1.0, 1.0, 1.0]
    m["extensions"]["KHR_materials_emissive_strength"] = {"emissiveStrength": strength}
    return m


def glass(name):
    """Placeholder glTF glass; the sidecar replaces it with the dispersive dielectric."""
    return {"name": name, "pbrMetallicRoughness": {"baseColorFactor": [1.0, 1.0, 1.0, 1.0],
                                                  "metallicFactor": 0.0, "roughnessFactor": 0.0}}


def write_sidecar(path, materials, world, render):
    doc = {"version": 1, "materials": materials, "world": world, "render": render}
    with open(path, "w") as f:
        json.dump(doc, f, indent=1)
        f.write("\n")


# ---------------------------------------------------------------- scenes/prism
PRISM_CAUCHY = {"a": 1.3, "b": 0.12}
PRISM_APEX_DEG = 55.0
PRISM_MIN_DEVIATION_UM = 0.5


def make_prism():
    g = Gltf()
    for m in (diffuse("Floor", (0.35, 0.35, 0.35)), diffuse("Screen", (0.8, 0.8, 0.8)),
              diffuse("Baffle", (0.0, 0.0, 0.0)), glass("PrismGlass"), emitter("Beam", 300.0)):
        g.material(m)

    # Prism in the xz plane (apex towards +z), standing on the floor.
    side, height = 0.3, 0.6
    ha = math.radians(PRISM_APEX_DEG / 2.0)
    b1, b2, apex = (-side * math.sin(ha), 0.0), (side * math.sin(ha), 0.0), (0.0, side * math.cos(ha))
    g.mesh("Prism", [(Geo().prism([b1, apex, b2], 0.0, height), "PrismGlass")])

    n_ref = PRISM_CAUCHY["a"] + PRISM_CAUCHY["b"] / PRISM_MIN_DEVIATION_UM ** 2
    phi = math.asin(n_ref * math.sin(ha)) - ha  # beam direction in xz, see tests/dispersion_prism.rs
    d_in = (math.cos(phi), 0.0, math.sin(phi))
    across = (-math.sin(phi), 0.0, math.cos(phi))
    d_out = (math.cos(phi), 0.0, -math.sin(phi))
    y_mid = 0.5 * height
    m1 = (0.5 * (b1[0] + apex[0]), y_mid, 0.5 * (b1[1] + apex[1]))
    m2 = (0.5 * (apex[0] + b2[0]), y_mid, 0.5 * (apex[1] + b2[1]))

    # Baffle with a slit 0.25 m before the entrance face, standing on the floor.
    slit = sub(m1, mul(d_in, 0.25))
    sw, sh, wide, tall = 0.08, 0.5, 2.0, 1.8
    up = (0.0, 1.0, 0.0)
    baffle = Geo()
    floor_at_slit = (slit[0], 0.0, slit[2])
    wside = 0.5 * (wide - sw)
    for s in (-1.0, 1.0):
        baffle.rect(add(floor_at_slit, add(mul(across, s * (sw / 2 + wside)), mul(up, tall / 2))),
                    across, up, wside, tall / 2, mul(d_in, -1.0))
    below = slit[1] - sh / 2
    above = tall - (slit[1] + sh / 2)
    baffle.rect(add(floor_at_slit, mul(up, below / 2)), across, up, sw / 2, below / 2, mul(d_in, -1.0))
    baffle.rect(add(floor_at_slit, mul(up, tall - above / 2)), across, up, sw / 2, above / 2,
                mul(d_in, -1.0))
    g.mesh("Baffle", [(baffle, "Baffle")])

    # The light: a strip 3 m behind the slit, narrow across the beam (0.1 rad seen from
    # the slit), tall (tilted rays draw the fan on the floor), facing the slit.
    lc = sub(slit, mul(d_in, 3.0))
    g.mesh("Light", [(Geo().rect((lc[0], 0.7, lc[2]), across, up, 0.15, 0.6, d_in), "Beam")])

    # Screen: 1.4 x 0.8 m, 1.1 m from the exit face, perpendicular to the 500 nm ray.
    sc = add(m2, mul(d_out, 1.1))
    tangent = norm(cross(d_out, up))
    screen_centre = (sc[0], 0.4, sc[2])
    g.mesh("Screen", [(Geo().rect(add(screen_centre, mul(tangent, 0.25)), tangent, up, 0.7, 0.4,
                                  mul(d_out, -1.0)), "Screen")])
    g.mesh("Floor", [(Geo().rect((0.0, 0.0, 0.0), (1.0, 0.0, 0.0), (0.0, 0.0, 1.0), 4.0, 4.0, up),
                      "Floor")])

    # Camera: above and in front, seeing the prism, the fan on the floor and the screen.
    target = add(add(m2, mul(d_out, 0.62)), add(mul(tangent, -0.05), (0.0, 0.22 - y_mid, 0.0)))
    eye = add(add(m2, mul(d_out, 0.1)), add(mul(tangent, 1.25), (0.0, 1.2 - y_mid, 0.0)))
    g.camera("Camera", eye, target, math.radians(58.0), 16.0 / 9.0)

    out = os.path.join(HERE, "prism")
    g.write(os.path.join(out, "prism.gltf"))
    write_sidecar(os.path.join(out, "prism.materials.json"),
                  {"PrismGlass": {"dielectric": {"cauchy": PRISM_CAUCHY, "roughness": 0.0}}},
                  {"color": [0.01, 0.01, 0.012], "strength": 1.0},
                  {"width": 480, "height": 270, "spp": 1024, "max_depth": 16, "wavelengths": "hero"})


# ---------------------------------------------------------------- scenes/rough_dispersive
def make_rough_dispersive():
    g = Gltf()
    for m in (diffuse("CheckerA", (0.75, 0.72, 0.65)), diffuse("CheckerB", (0.10, 0.22, 0.45)),
              glass("RoughSF11"), emitter("Light", 12.0)):
        g.material(m)
    a, b = Geo(), Geo()
    n, size = 10, 0.4
    for i in range(n):
        for j in range(n):
            c = ((i - n / 2 + 0.5) * size, 0.0, (j - n / 2 + 0.5) * size)
            (a if (i + j) % 2 == 0 else b).rect(c, (1.0, 0.0, 0.0), (0.0, 0.0, 1.0),
                                                size / 2, size / 2, (0.0, 1.0, 0.0))
    g.mesh("Floor", [(a, "CheckerA"), (b, "CheckerB")])
    g.mesh("Sphere", [(Geo().sphere((-0.35, 0.45, 0.0), 0.45), "RoughSF11")])
    g.mesh("Slab", [(Geo().box((0.25, 0.0, -0.45), (0.95, 0.5, -0.2)), "RoughSF11")])
    # Square light above, behind and to the left: refracted light and coloured fringes in
    # the glass's caustics on the floor.
    g.mesh("Light", [(Geo().rect((-0.6, 2.2, -1.2), norm((1.0, 0.0, 0.0)), norm((0.0, 0.6, 1.0)),
                                 0.4, 0.4, norm((0.5, -1.0, 0.6))), "Light")])
    g.camera("Camera", (0.2, 1.5, 3.0), (0.05, 0.3, -0.15), math.radians(36.0), 4.0 / 3.0)

    out = os.path.join(HERE, "rough_dispersive")
    g.write(os.path.join(out, "rough_dispersive.gltf"))
    write_sidecar(os.path.join(out, "rough_dispersive.materials.json"),
                  {"RoughSF11": {"dielectric": {"preset": "SF11", "roughness": 0.2}}},
                  {"color": [0.05, 0.05, 0.06], "strength": 1.0},
                  {"width": 400, "height": 300, "spp": 256, "max_depth": 32, "wavelengths": "hero"})


if __name__ == "__main__":
    make_prism()
    make_rough_dispersive()

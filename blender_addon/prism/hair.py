# SPDX-License-Identifier: MIT
"""Hair as geometry: particle hair and Curves objects become round tubes of triangles.

Cycles renders hair as round curves ("3D Curves") of the radius Blender gives each point. The
renderer has no curve primitive yet, so each strand becomes a tube: a ring of `sides` vertices
around every point, in the plane normal to the strand, with radial (smooth) normals, joined ring
to ring. A regular N-gon of circumradius R has mean projected width 2 N R sin(pi/N) / pi (its
perimeter over pi, Cauchy's formula), a circle of radius R has 2 R: the rings are widened by
pi / (N sin(pi/N)) (2.6% for the 8 sides used) so a strand covers on average what Cycles' round curve
covers.

What Blender gives, as Cycles reads it:
- particle hair (ParticleSettings type HAIR, render as PATH): 2^steps + 1 keys per strand
  (Render Steps for renders, Viewport Steps in the viewport), children only when the system has
  them (else the parents), in world space (`ParticleSystem.co_hair`). The radius runs from
  Diameter Root to Tip (both x Diameter Scale, halved: the UI's values are diameters) along the
  strand's arc length, bent by Shape (-1..1: (1 - t)^(1 + shape) below 0, (1 - t)^(1 / (1 -
  shape)) above), and is 0 at the last key with Close Tip; the material is the system's slot.
- Curves objects: the evaluated points and curve offsets in object space, the per-point float
  attribute `radius` (none: radius 0, invisible, as in Cycles), the object's first material.
"""

import math

import numpy as np

DEFAULT_SIDES = 8


def shape_radius(shape, root, tip, t):
    """Radius at arc-length fraction `t` (array) of a strand of root and tip radius and Shape."""
    r = 1.0 - np.clip(t, 0.0, 1.0)
    if shape < 0.0:
        r = np.power(r, 1.0 + shape)
    elif shape > 0.0:
        r = np.power(r, 1.0 / (1.0 - shape))
    return r * (root - tip) + tip


def tube_mesh(points, radii, offsets, sides=DEFAULT_SIDES):
    """Tubes around polylines. `points` (P, 3), `radii` (P,), `offsets` (C + 1,): curve c is
    points[offsets[c]:offsets[c + 1]]. Returns (positions (V, 3), normals (V, 3), triangle
    indices (T * 3,)) as float32 / uint32, or None when no curve has two points."""
    points = np.asarray(points, np.float64).reshape(-1, 3)
    radii = np.asarray(radii, np.float64).reshape(-1)
    offsets = np.asarray(offsets, np.int64)
    counts = np.diff(offsets)
    keep = counts >= 2
    if not keep.any():
        return None
    if not keep.all():
        idx = np.concatenate([np.arange(offsets[c], offsets[c + 1]) for c in np.nonzero(keep)[0]])
        points, radii = points[idx], radii[idx]
        counts = counts[keep]
        offsets = np.concatenate([[0], np.cumsum(counts)])
    n = len(points)
    start = np.repeat(offsets[:-1], counts)
    end = np.repeat(offsets[1:], counts) - 1
    i = np.arange(n)
    # Tangents by central differences inside a curve, one-sided at its ends.
    tangent = points[np.minimum(i + 1, end)] - points[np.maximum(i - 1, start)]
    tangent /= np.maximum(np.linalg.norm(tangent, axis=1, keepdims=True), 1e-30)
    # One reference direction per curve, across its chord, so that consecutive rings line up
    # (a per-point choice could flip between neighbours and twist the tube).
    chord = points[offsets[1:] - 1] - points[offsets[:-1]]
    axis = np.eye(3)[np.argmin(np.abs(chord), axis=1)]
    ref = np.repeat(np.cross(chord, axis), counts, axis=0)
    u = np.cross(tangent, ref)
    small = np.linalg.norm(u, axis=1) < 1e-8 * np.maximum(np.linalg.norm(ref, axis=1), 1e-30)
    if small.any():  # the strand turns along its reference: any normal to the tangent will do
        alt = np.eye(3)[np.argmin(np.abs(tangent[small]), axis=1)]
        u[small] = np.cross(tangent[small], alt)
    u /= np.maximum(np.linalg.norm(u, axis=1, keepdims=True), 1e-30)
    v = np.cross(tangent, u)
    angles = 2.0 * math.pi * np.arange(sides) / sides
    ring = np.cos(angles)[None, :, None] * u[:, None, :] + np.sin(angles)[None, :, None] * v[:, None, :]
    widen = math.pi / (sides * math.sin(math.pi / sides))
    positions = points[:, None, :] + (widen * radii)[:, None, None] * ring
    # Segments: point j to j + 1 within a curve.
    seg = i[i < end]
    k = np.arange(sides)
    a = seg[:, None] * sides + k[None, :]
    b = seg[:, None] * sides + (k[None, :] + 1) % sides
    c, d = b + sides, a + sides
    tris = np.stack([a, b, c, a, c, d], axis=-1).reshape(-1)
    return (
        positions.reshape(-1, 3).astype(np.float32),
        ring.reshape(-1, 3).astype(np.float32),
        tris.astype(np.uint32),
    )


def particle_strands(ob, ps, viewport=False):
    """(points (P, 3) in world space, radii (P,), offsets (C + 1,)) of a particle hair system of
    evaluated object `ob`, or None when it draws no strands."""
    st = ps.settings
    steps = (1 << int(st.display_step if viewport else st.render_step)) + 1
    if getattr(st, "kink", "NO") == "SPIRAL":
        steps += int(getattr(st, "kink_extra_steps", 0))
    n_parents = len(ps.particles)
    n_children = len(ps.child_particles)
    if viewport:
        n_children = int(n_children * st.display_percentage / 100.0)
    if st.child_type != "NONE" and n_children > 0:
        strands = range(n_parents, n_parents + n_children)
    else:
        strands = range(n_parents)
    if len(strands) == 0:
        return None
    co = np.array([ps.co_hair(ob, particle_no=p, step=s) for p in strands for s in range(steps)], np.float64)
    co = co.reshape(len(strands), steps, 3)
    seg = np.linalg.norm(np.diff(co, axis=1), axis=2)
    arc = np.concatenate([np.zeros((len(strands), 1)), np.cumsum(seg, axis=1)], axis=1)
    total = arc[:, -1:]
    t = np.where(total > 0.0, arc / np.where(total > 0.0, total, 1.0), 0.0)
    half = 0.5 * st.radius_scale
    radii = shape_radius(st.shape, half * st.root_radius, half * st.tip_radius, t)
    if st.use_close_tip:
        radii[:, -1] = 0.0
    offsets = np.arange(len(strands) + 1) * steps
    return co.reshape(-1, 3), radii.reshape(-1), offsets


def curves_strands(curves):
    """(points (P, 3) in object space, radii (P,), offsets (C + 1,)) of evaluated Curves data,
    and whether it has a radius attribute."""
    n_points, n_curves = len(curves.points), len(curves.curves)
    if n_points == 0 or n_curves == 0:
        return None, False
    pos = np.empty(n_points * 3, np.float32)
    curves.position_data.foreach_get("vector", pos)
    offsets = np.empty(n_curves + 1, np.int32)
    curves.curve_offset_data.foreach_get("value", offsets)
    attr = curves.attributes.get("radius")
    has_radius = attr is not None and attr.domain == "POINT" and attr.data_type == "FLOAT"
    radii = np.zeros(n_points, np.float32)
    if has_radius:
        attr.data.foreach_get("value", radii)
    return (pos.reshape(-1, 3), radii, offsets), has_radius

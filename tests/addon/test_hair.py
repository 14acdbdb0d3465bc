"""Hair against Cycles in the bpy 5.0.1 wheel: particle hair and a Curves object.

    .venv-bpy/bin/python tests/addon/test_hair.py

Left: a plane growing particle hair (Principled, red; Diameter Scale 0.03, Root 1, Tip 0.2,
Shape 0.3, tips closed, 150 parents with 3 interpolated children each (1 in the viewport), 2^3 + 1 keys, directions randomised a little), its
emitter hidden. Right: a Curves object of 60 curves fanned out, each
with its own radius per point (Principled, blue). Film Transparent, a uniform grey world and a
sun: the alpha is the hair's coverage, the colour its shading. Prism renders the hair as tubes
(hair.py); Cycles as round curves. Checked per side: coverage (mean alpha) and premultiplied
colour means; and the Principled Hair BSDF's approximation (a warning, a plausible colour).
"""

import math
import os
import sys
import tempfile

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)

import bpy  # noqa: E402
import numpy as np  # noqa: E402

import common  # noqa: E402
from common import check  # noqa: E402

W, H = 128, 64
SPP = 64


def scene():
    common.enable_addon()
    common.reset()
    sc = bpy.context.scene
    red = common.material("Red", "ShaderNodeBsdfPrincipled", (0.8, 0.15, 0.1), Roughness=0.5)
    blue = common.material("Blue", "ShaderNodeBsdfPrincipled", (0.1, 0.2, 0.8), Roughness=0.5)
    # Particle hair on a small plane at the left, growing up (+Z).
    scalp = common.mesh_object("Scalp", common.plane(1.2), red, location=(-1.0, 0.0, 0.0))
    mod = scalp.modifiers.new("Hair", "PARTICLE_SYSTEM")
    st = mod.particle_system.settings
    st.type = "HAIR"
    st.count = 150
    # Interpolated children: 3 per parent in renders, 1 in the viewport (an export that took
    # the viewport's count would cover a third of what Cycles covers).
    st.child_type = "INTERPOLATED"
    st.rendered_child_count = 3
    setattr(st, "child_percent" if hasattr(st, "child_percent") else "child_nbr", 1)
    st.hair_length = 1.2
    st.render_step = 3
    st.display_step = 3
    st.radius_scale = 0.03
    st.root_radius = 1.0
    st.tip_radius = 0.2
    st.shape = 0.3
    st.use_close_tip = True
    st.factor_random = 0.15  # some spread of directions
    st.material = 1
    scalp.show_instancer_for_render = False
    scalp.show_instancer_for_viewport = False
    # A Curves object at the right: a fan of curves in the XZ plane, radius tapering.
    hc = bpy.data.hair_curves.new("Fan")
    n, k = 60, 6
    hc.add_curves([k] * n)
    pos = []
    for c in range(n):
        a = -0.9 + 1.8 * c / (n - 1)
        for j in range(k):
            t = j / (k - 1)
            pos.append((0.25 * math.sin(a) * t * 3 + 0.05 * math.sin(3 * t + c), 0.3 * math.cos(a + c) * t, 1.2 * t * math.cos(0.5 * a)))
    hc.position_data.foreach_set("vector", [x for p in pos for x in p])
    radius = hc.attributes.get("radius") or hc.attributes.new("radius", "FLOAT", "POINT")
    radius.data.foreach_set("value", [0.012 * (1.0 - 0.7 * (j / (k - 1))) for c in range(n) for j in range(k)])
    hc.materials.append(blue)
    fan = bpy.data.objects.new("Fan", hc)
    fan.location = (1.0, 0.0, 0.0)
    sc.collection.objects.link(fan)
    common.light("Sun", "SUN", 3.0, (0, 0, 5), rotation=(0.6, 0.2, 0.0))
    common.world((0.5, 0.5, 0.5), 1.0)
    common.camera((0.0, -5.0, 0.7), (0.0, 0.0, 0.6), lens=50.0)
    sc.render.resolution_x, sc.render.resolution_y = W, H
    sc.render.resolution_percentage = 100
    sc.render.film_transparent = True
    return sc


def main():
    sc = scene()
    out = tempfile.mkdtemp(prefix="prism_addon_test_hair_")
    from prism import engine, export

    # The export: tubes for both, no "not rendered" warning.
    dg = bpy.context.evaluated_depsgraph_get()
    ex = export.Exporter(dg, out, "hair", W, H)
    ex.run(export.render_settings(sc))
    names = [m["name"] for m in ex.meshes]
    check("Scalp.Hair" in names and "Fan" in names, "hair and curves exported as meshes (%s)" % names)
    check(not [w for w in ex.warnings if "not rendered" in w], "no 'not rendered' warnings: %s" % ex.warnings)

    prism = common.render_engine_rgba(sc, "prism", SPP, out, "hair", 8)
    # 450 children x 8 segments x 8 sides x 2 triangles, plus the Curves and the emitter.
    tris = engine.LAST.get("triangles", 0)
    check(tris >= 450 * 8 * 8 * 2, "the render exported the render's 450 child strands (%d triangles)" % tris)
    check(not engine.LAST.get("error"), "Prism rendered (%s)" % engine.LAST.get("error"))
    cycles = common.render_engine_rgba(sc, "cycles", SPP, out, "hair", 8)
    check(np.isfinite(prism).all(), "finite pixels")
    for side, cols in (("particle hair (left)", slice(0, W // 2)), ("curves (right)", slice(W // 2, W))):
        ap, ac = prism[:, cols, 3].mean(), cycles[:, cols, 3].mean()
        check(ac > 0.02, "%s: Cycles' coverage %.4f is not empty" % (side, ac))
        check(abs(ap / ac - 1.0) < 0.06, "%s: coverage (mean alpha) %.4f vs Cycles %.4f (6%%)" % (side, ap, ac))
        cp, cc = prism[:, cols, :3].mean(axis=(0, 1)), cycles[:, cols, :3].mean(axis=(0, 1))
        # The tubes' flat facets shade a little darker than a round curve where light grazes
        # them (light below a facet's plane is cut though the smooth normal faces it): 6-8%.
        check(np.all(np.abs(cp / cc - 1.0) < 0.10), "%s: colour means %s vs Cycles %s (10%%)" % (side, cp.round(4), cc.round(4)))

    # Principled Hair BSDF: approximated by a Principled of the hair's colour, with a warning.
    mat = bpy.data.materials.new("Brown")
    mat.use_nodes = True
    nt = mat.node_tree
    nt.nodes.clear()
    hair_node = nt.nodes.new("ShaderNodeBsdfHairPrincipled")
    hair_node.parametrization = "MELANIN"
    hair_node.inputs["Melanin"].default_value = 0.8
    hair_node.inputs["Melanin Redness"].default_value = 0.5
    nt.links.new(hair_node.outputs[0], nt.nodes.new("ShaderNodeOutputMaterial").inputs["Surface"])
    bpy.data.objects["Scalp"].material_slots[0].material = mat
    ex = export.Exporter(bpy.context.evaluated_depsgraph_get(), out, "brown", W, H)
    ex.run(export.render_settings(sc))
    g = next(m for m in ex.materials if m["name"] == "Brown")
    base = g["pbrMetallicRoughness"]["baseColorFactor"][:3]
    check(any("Principled Hair BSDF" in w and "approximated" in w for w in ex.warnings),
          "a warning says the Principled Hair BSDF is approximated")
    check(base[0] > base[1] > base[2] and 0.01 < base[0] < 0.5, "melanin 0.8 gives a brown (%s)" % [round(c, 3) for c in base])
    import shutil

    shutil.rmtree(out, ignore_errors=True)


if __name__ == "__main__":
    main()
    print("hair test passed")

"""Energy-conserving rough materials against Cycles in the bpy wheel (Blender 5.0.1), issue 14:
rough glass spheres (Glass BSDF, IOR 1.5, roughness 0.2 / 0.5 / 0.8), a rough metal sphere
(Principled, metallic 1, roughness 0.6) and a dark rough Principled floor (base 0.05, roughness
0.8), under an area light and a grey world. Cycles' Glass and Principled BSDFs use
multiple-scattering GGX by default (energy compensation since 4.0) and its Principled layers the
specular over the diffuse base by albedo scaling; Prism compensates with tabulated albedos
(src/bsdf/energy.rs). Cycles unbiased (no clamping, Filter Glossy 0, 16 bounces), 512 spp;
Prism 256 spp, max depth 16. Run by run_addon_tests.sh:

    .venv-bpy/bin/python tests/addon/test_energy_parity.py [TEST_NAME ...]

Tolerances on the per-channel mean over a box inside each object (Prism / Cycles): glass 0.2
and 0.5: 3%, metal and floor 2% (the issue's bounds); glass 0.8: 5%. Measured (Cycles 2048 spp,
Prism 1024): glass 0.997 / 0.993 / 0.964, metal 0.993 / 1.002 / 0.992, floor 0.986-0.989. Since
the Principled follows Cycles' view-direction layering, real Fresnel curve and lobe-shaped
multiple scattering (2026-12-04; Cycles 512, Prism 256 spp): metal 0.985 / 0.993 / 0.983, floor
0.99 (the spectral evaluation of the coloured metal's multiple-scattering Fresnel is the likely
rest).

Why 5% for the roughest glass: Cycles' rough-refraction eval (bsdf_microfacet.h, "TODO: check if
the refraction configuration is valid") keeps microfacets that face away from one of the two
directions, which pbrt-v4, Mitsuba and Prism discard as physically impossible. It matters where
light leaves rough glass obliquely: single-scattering GGX, light through a flat rough (0.5) slab
seen from below, Prism / Cycles = 0.999 at normal exit, 0.97 at 45 degrees, 0.905 at 70; Prism
with that check removed gives 1.02 at 70 degrees. A rough sphere is lit mostly through such
exits. The white furnace (uniform world, 128 bounces) says Prism conserves energy there
(0.999-1.000 at roughness 0.5-1) where Cycles returns 0.987.

Coat (test_coat_matches_cycles): Principled Coat smooth over a rough red base, rough with a
tint (0.9, 0.6, 0.3) over grey, weight 0.7 over a rough metal, and a plain Principled: within 5%
(measured 0.985-1.001; with the coat's exact Fresnel and lobe-shaped multiple scattering,
0.994-0.999).

Specular Tint (test_specular_tint_matches_cycles, 3%): F82-tinted metals 1.00 / 0.977-1.01,
tinted dielectrics 0.98-1.00 and 1.00-1.028 (Specular IOR Level 0.8). The last one's blue: Cycles
scales the base under a tinted specular layer by one minus the largest channel of the layer's
albedo (closure_layering_weight's reduce_max), Prism per wavelength by what the layer lets
through, which conserves energy in every channel.

Sheen (test_sheen_matches_cycles, 15%), Coat and Sheen from textures
(test_textured_coat_and_sheen_match_cycles) and inside Mix Shader leaves
(test_layers_in_mix_leaves_match_cycles): see their docstrings.

Without energy compensation (`"model": "gltf"`, single scattering) the roughness-0.8 sphere is
at 0.33 of Cycles and the metal at 0.81 (the scene lit by the area light alone), so the test
fails when compensation breaks.
"""

import os
import sys
import tempfile

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import bpy  # noqa: E402
import numpy as np  # noqa: E402

import common as C  # noqa: E402

OUT = tempfile.mkdtemp(prefix="prism_addon_test_energy_")
CYCLES_SPP = 512
PRISM_SPP = 256
# The later tests' (their bounds leave room for the extra noise; the suite's time is budgeted).
QUICK_SPP = (256, 128)
W, H = 200, 80
RADIUS = 0.6
# (object name, x position); glass roughnesses then the metal.
SPHERES = [("Glass02", -2.1), ("Glass05", -0.7), ("Glass08", 0.7), ("Metal06", 2.1)]


# Principled spheres of the coat test: (name, base colour, inputs).
COATED = [
    ("CoatRed", (0.8, 0.1, 0.1), {"Roughness": 0.5, "Coat Weight": 1.0, "Coat Roughness": 0.03}),
    ("CoatTint", (0.8, 0.8, 0.8), {"Roughness": 0.4, "Coat Weight": 1.0, "Coat Roughness": 0.2,
                                   "Coat Tint": (0.9, 0.6, 0.3, 1.0)}),
    ("CoatMetal", (0.9, 0.9, 0.9), {"Metallic": 1.0, "Roughness": 0.5, "Coat Weight": 0.7, "Coat Roughness": 0.1}),
    ("Plain", (0.2, 0.5, 0.8), {"Roughness": 0.3}),
]


# Blender 3.x's Clearcoat (the Disney model's): a smooth and a rough coat over dielectrics, a
# coat over a metal, and one over a near-black base.
CLEARCOAT_3X = [
    ("Clear", (0.8, 0.1, 0.1), {"Roughness": 0.5, "Clearcoat": 1.0, "Clearcoat Roughness": 0.03}),
    ("ClearRough", (0.3, 0.3, 0.3), {"Roughness": 0.6, "Clearcoat": 1.0, "Clearcoat Roughness": 0.3}),
    ("ClearMetal", (0.9, 0.9, 0.9), {"Metallic": 1.0, "Roughness": 0.5, "Clearcoat": 0.7,
                                     "Clearcoat Roughness": 0.1}),
    ("ClearDark", (0.03, 0.03, 0.03), {"Roughness": 0.4, "Clearcoat": 1.0, "Clearcoat Roughness": 0.1}),
]


# Specular Tint (4.x colour): the metal's F82 edge tint, the dielectric's F0 tint.
TINTED = [
    ("TintMetal", (0.9, 0.9, 0.9), {"Metallic": 1.0, "Roughness": 0.3, "Specular Tint": (1.0, 0.4, 0.1, 1.0)}),
    ("TintMetalRough", (0.95, 0.7, 0.5), {"Metallic": 1.0, "Roughness": 0.7, "Specular Tint": (0.3, 0.6, 1.0, 1.0)}),
    ("TintDielectric", (0.05, 0.05, 0.05), {"Roughness": 0.2, "Specular Tint": (0.2, 0.6, 1.0, 1.0)}),
    ("TintLevel", (0.3, 0.3, 0.3), {"Roughness": 0.4, "Specular IOR Level": 0.8, "Specular Tint": (1.0, 0.8, 0.5, 1.0)}),
]


def scene(principled=None, sun=False):
    """The spheres on a dark rough floor under an area light and a grey world; with `sun`, on a
    grey floor (base 0.6, roughness 0.5) under a sun alone."""
    C.reset()
    sc = bpy.context.scene
    floor_color, floor_roughness = ((0.6, 0.6, 0.6), 0.5) if sun else ((0.05, 0.05, 0.05), 0.8)
    floor = C.material("Floor", "ShaderNodeBsdfPrincipled", floor_color, Roughness=floor_roughness)
    C.mesh_object("Floor", C.plane(30.0), floor)
    if principled:
        for (name, x), (mname, color, inputs) in zip(SPHERES, principled):
            mat = C.material(mname, "ShaderNodeBsdfPrincipled", color, **inputs)
            C.mesh_object(name, C.sphere(RADIUS, 64, 32), mat, location=(x, 0, RADIUS), smooth=True)
    else:
        for (name, x), rough in zip(SPHERES[:3], (0.2, 0.5, 0.8)):
            glass = C.material(name, "ShaderNodeBsdfGlass", (1.0, 1.0, 1.0), Roughness=rough, IOR=1.5)
            C.mesh_object(name, C.sphere(RADIUS, 64, 32), glass, location=(x, 0, RADIUS), smooth=True)
        metal = C.material("Metal06", "ShaderNodeBsdfPrincipled", (0.9, 0.6, 0.3), Metallic=1.0, Roughness=0.6)
        C.mesh_object("Metal06", C.sphere(RADIUS, 64, 32), metal, location=(SPHERES[3][1], 0, RADIUS), smooth=True)
    if sun:
        C.light("Sun", "SUN", 3.0, (0.0, 0.0, 5.0), rotation=(0.6, 0.0, 0.4), angle=0.01)
        C.world((0.0, 0.0, 0.0), 0.0)
    else:
        C.light("Area", "AREA", 300.0, (-1.0, -2.0, 4.0), rotation=(0.45, 0.0, -0.2), shape="SQUARE", size=2.0)
        C.world((0.3, 0.3, 0.3), 1.0)
    C.camera((0.0, -6.5, 1.6), (0.0, 0.0, 0.55), lens=40.0)
    sc.render.resolution_x, sc.render.resolution_y, sc.render.resolution_percentage = W, H, 100
    return sc


def pixel_box(sc, name, fraction=0.6):
    """Rows and columns of a box inside object `name`'s silhouette (its centre +- fraction of
    its projected radius)."""
    from bpy_extras.object_utils import world_to_camera_view
    from mathutils import Vector

    bpy.context.view_layer.update()  # the camera's matrix_world
    ob = bpy.data.objects[name]
    c = world_to_camera_view(sc, sc.camera, ob.location)
    edge = world_to_camera_view(sc, sc.camera, ob.location + Vector((RADIUS, 0, 0)))
    r = abs(edge.x - c.x) * W * fraction
    cx, cy = c.x * W, c.y * H  # the EXR's rows run bottom-up, as camera-view y
    return slice(int(cy - r), int(cy + r) + 1), slice(int(cx - r), int(cx + r) + 1)


def pixel_ring(sc, name, inner=0.75, outer=0.95):
    """A mask of the pixels of object `name` between `inner` and `outer` of its projected radius
    from its centre: the rim, where a sheen shows most."""
    rows, cols = pixel_box(sc, name, 1.0)
    cy, cx = 0.5 * (rows.start + rows.stop - 1), 0.5 * (cols.start + cols.stop - 1)
    r = 0.5 * (rows.stop - rows.start - 1)
    y, x = np.mgrid[0:H, 0:W]
    d = np.hypot(y - cy, x - cx) / r
    return (d >= inner) & (d <= outer)


def means(px, boxes):
    out = {}
    for name, (rows, cols) in boxes.items():
        out[name] = px[rows, cols].mean(axis=(0, 1))
    # The floor in front of the spheres (the image's bottom rows, first in Blender's order).
    out["Floor"] = px[:int(H * 0.12), :].mean(axis=(0, 1))
    return out


def test_rough_glass_metal_and_floor_match_cycles():
    sc = scene()
    boxes = {name: pixel_box(sc, name) for name, _ in SPHERES}
    C.check(all(8 <= r.stop - r.start <= 40 and H * 0.12 <= r.start and r.stop <= H and 0 <= c.start and c.stop <= W
                for r, c in boxes.values()),
            "object boxes of 8-40 px inside the image, above the floor strip: %s"
            % {k: (r.start, r.stop, c.start, c.stop) for k, (r, c) in boxes.items()})
    c = means(C.render_engine(sc, "cycles", CYCLES_SPP, OUT, "energy", bounces=16), boxes)
    p = means(C.render_engine(sc, "prism", PRISM_SPP, OUT, "energy", bounces=16), boxes)
    for name, tol in (("Glass02", 0.03), ("Glass05", 0.03), ("Glass08", 0.05), ("Metal06", 0.02), ("Floor", 0.02)):
        ratio = p[name] / c[name]
        C.check(all(abs(r - 1) < tol for r in ratio),
                "%s: mean Prism / Cycles %s within %d%% (Cycles %s)"
                % (name, ratio.round(3), round(tol * 100), c[name].round(4)))


def test_coat_matches_cycles():
    """Principled Coat (smooth over a rough red base, rough with a tint, over a metal) and a
    plain Principled beside them; bound 5% (the issue's). The spheres are named after the
    glass test's slots."""
    if bpy.app.version < (4, 0, 0):
        return  # Coat Weight / Tint are Blender 4.x inputs
    compare_principled("coat", COATED, 0.05)


# Glass and Glossy BSDFs by distribution: (sphere name, node, colour, inputs, distribution).
DISTRIBUTIONS = [
    ("GlassGGX", "ShaderNodeBsdfGlass", (1.0, 1.0, 1.0), {"Roughness": 0.5, "IOR": 1.5}, "GGX"),
    ("GlassMulti", "ShaderNodeBsdfGlass", (1.0, 1.0, 1.0), {"Roughness": 0.5, "IOR": 1.5}, "MULTI_GGX"),
    ("GlossyGGX", "ShaderNodeBsdfGlossy", (0.9, 0.6, 0.3), {"Roughness": 0.6}, "GGX"),
    ("GlossyMulti", "ShaderNodeBsdfGlossy", (0.9, 0.6, 0.3), {"Roughness": 0.6}, "MULTI_GGX"),
]


def test_single_scattering_distributions_match_cycles():
    """A Glass or Glossy BSDF set to GGX (Blender 3.x's default for Glossy; Beckmann for Glass)
    scatters once in Cycles: the add-on renders it with the glTF model (no multiple-scattering
    energy), beside the same nodes at Multiscatter GGX (the default in 4.x and later). Means
    within 4% of Cycles: measured 0.98 / 0.98 (glass), 1.00 / 1.00 (glossy); with every
    distribution rendered multiple-scattering the GGX glass was about 1.2x Cycles'."""
    if bpy.app.version < (4, 0, 0):
        return  # 3.x's GGX glass differs from 4.x's (measured 1.07 there); Beckmann glass 1.00
    sc = scene([(name, (0.5, 0.5, 0.5), {}) for name, _, _, _, _ in DISTRIBUTIONS])
    for name, kind, color, inputs, dist in DISTRIBUTIONS:
        nt = bpy.data.materials[name].node_tree
        nt.nodes.clear()
        out = nt.nodes.new("ShaderNodeOutputMaterial")
        node = C.shader_node(nt, kind, color, **inputs)
        node.distribution = dist
        nt.links.new(node.outputs[0], out.inputs["Surface"])
    boxes = {name: pixel_box(sc, name) for name, _ in SPHERES}
    c = means(C.render_engine(sc, "cycles", QUICK_SPP[0], OUT, "distributions", bounces=16), boxes)
    p = means(C.render_engine(sc, "prism", QUICK_SPP[1], OUT, "distributions", bounces=16), boxes)
    prism = sys.modules["prism"]
    C.check(not prism.engine.LAST["warnings"], "no warnings: %s" % prism.engine.LAST["warnings"])
    for (slot, _), (mname, _, _, _, _) in zip(SPHERES, DISTRIBUTIONS):
        ratio = p[slot] / c[slot]
        C.check(all(abs(r - 1) < 0.04 for r in ratio), "%s: mean Prism / Cycles %s within 4%% (Cycles %s)"
                % (mname, ratio.round(3), c[slot].round(4)))


# Blender 3.x's Principled BSDF (the Disney model in Cycles 3.x): a red and a grey dielectric, a
# metal and a near-black dielectric under a full Sheen.
PRINCIPLED_3X = [
    ("V1Red", (0.8, 0.1, 0.1), {"Roughness": 0.5}),
    ("V1Grey", (0.3, 0.3, 0.3), {"Roughness": 0.6}),
    ("V1Metal", (0.9, 0.9, 0.9), {"Metallic": 1.0, "Roughness": 0.5}),
    ("V1DarkSheen", (0.03, 0.03, 0.03), {"Roughness": 0.4, "Sheen": 1.0}),
]


def test_principled_3x_matches_cycles():
    """Blender 3.x's Principled BSDF against Cycles 3.x (Debian's Blender 3.4): Cycles 3.x
    renders it as the Disney BRDF, Burley's diffuse base with the single-scattering GGX specular
    layer added on top (not dimming it) and Cycles 3.x's Fresnel; the add-on exports it as
    `"model": "principled_v1"` (src/bsdf/metallic_roughness.rs), and its Sheen as the Disney
    sheen (src/bsdf/sheen.rs). Sphere means and rims within 3%: measured 1.000-1.003 (means),
    0.998-1.001 (rims; the sheened sphere's rim without its sheen 0.94); with Prism's 4.x model
    (Lambert under an energy-conserving specular layer) the means were 0.92-0.95
    (dielectrics), 0.88 (near-black) and 1.09 (metal)."""
    if bpy.app.version >= (4, 0, 0):
        return  # Principled v2 (test_rough_glass_metal_and_floor_match_cycles and the others)
    compare_principled("principled3x", PRINCIPLED_3X, 0.03, spp=QUICK_SPP, rim_tol=0.03)
    prism = sys.modules["prism"]
    C.check(prism.engine.LAST["warnings"] == [], "no warnings")


LO_3X, HI_3X = 0.75, 1.35


def test_clearcoat_3x_matches_cycles():
    """Blender 3.x's Clearcoat against Cycles 3.x (Debian's Blender 3.4, `blender -b`): Cycles
    adds the Disney clear coat, 0.25 x Clearcoat x a Schlick-like Fresnel of F0 0.04 over a
    GTR1 distribution, on top of the base without dimming it; the add-on exports a coat of
    weight 0.25 x Clearcoat that adds without dimming (`prism_coat_additive`). What the coat
    adds (each sphere's mean with its coat minus without) is compared. Prism's coat lobe is
    GGX, whose highlight differs from the heavy-tailed GTR1's: measured 0.91 (smooth coat), 1.18
    (rough), 1.28 (over a metal), 0.82 (over black); bound [0.75, 1.35]. (Until the add-on
    scaled Cycles 3.x's area lights by pi/4 at the default spread too, the scene's light was
    1.27x too bright in Prism and these read 1.12 / 1.44 / 1.53 / 0.97; before the coat was
    made additive, 0.76 / 0.99 / 0.28.) The bases are Principled v1 as in Cycles 3.x
    (test_principled_3x_matches_cycles)."""
    if bpy.app.version >= (4, 0, 0):
        return  # 4.x has Coat Weight (test_coat_matches_cycles)
    uncoated = [(name, color, {k: v for k, v in inputs.items() if not k.startswith("Clearcoat")})
                for name, color, inputs in CLEARCOAT_3X]
    out = {}
    for label, spheres in (("clearcoat3x", CLEARCOAT_3X), ("noclearcoat3x", uncoated)):
        sc = scene(spheres)
        boxes = {name: pixel_box(sc, name) for name, _ in SPHERES}
        for engine, spp in zip(("cycles", "prism"), QUICK_SPP):
            out[label, engine] = means(C.render_engine(sc, engine, spp, OUT, label, bounces=16), boxes)
    prism = sys.modules["prism"]
    C.check(not prism.engine.LAST["warnings"], "no warnings: %s" % prism.engine.LAST["warnings"])
    results = []
    for (slot, _), (mname, _, _) in zip(SPHERES, CLEARCOAT_3X):
        added = {e: (out["clearcoat3x", e][slot] - out["noclearcoat3x", e][slot]).mean() for e in ("cycles", "prism")}
        results.append((mname, added["prism"], added["cycles"], added["prism"] / added["cycles"]))
        print("  %s: the coat adds %.4f in Prism, %.4f in Cycles: %.3f" % results[-1])
    for mname, p_added, c_added, ratio in results:
        C.check(LO_3X < ratio < HI_3X, "%s: the coat adds %.4f in Prism, %.4f in Cycles: %.3f in [%.2f, %.2f]"
                % (mname, p_added, c_added, ratio, LO_3X, HI_3X))
    # On a Mix Shader leaf the 3.x Clearcoat adds without dimming too: the material's coat is
    # marked additive, as for a Principled BSDF on the output.
    import json
    import tempfile as tf
    from prism import export
    scene(CLEARCOAT_3X)
    mat = bpy.data.materials.new("MixedClearcoat")
    mat.use_nodes = True
    nt = mat.node_tree
    pr = next(n for n in nt.nodes if n.type == "BSDF_PRINCIPLED")
    pr.inputs["Clearcoat"].default_value = 1.0
    mix = nt.nodes.new("ShaderNodeMixShader")
    diffuse = nt.nodes.new("ShaderNodeBsdfDiffuse")
    nt.links.new(pr.outputs[0], mix.inputs[1])
    nt.links.new(diffuse.outputs[0], mix.inputs[2])
    nt.links.new(mix.outputs[0], next(n for n in nt.nodes if n.type == "OUTPUT_MATERIAL").inputs["Surface"])
    next(o for o in bpy.data.objects if o.type == "MESH").data.materials[0] = mat
    gltf, mj, _w, _t = export.export_scene(bpy.context.evaluated_depsgraph_get(), tf.mkdtemp(dir=OUT))
    with open(gltf) as f:
        gm = next(m for m in json.load(f)["materials"] if m["name"] == "MixedClearcoat")
    C.check(gm.get("extras", {}).get("prism_coat_additive") is True, "a mixed 3.x Clearcoat is additive: %s" % gm)
    # Its Principled leaf's F0 is 0.08 x Specular (0.04) whatever the IOR (3.x's default 1.45),
    # as on the output: the leaf's specular factor times the material's IOR's own F0.
    with open(mj) as f:
        graph = json.load(f)["materials"]["MixedClearcoat"]["graph"]
    ior = gm.get("extensions", {}).get("KHR_materials_ior", {}).get("ior", 1.5)
    leaf = next(c for c in graph["closures"] if c["inputs"].get("metallic") is not None
                and c["inputs"].get("transmission") is not None and "coat_weight" in c["inputs"])
    spec = leaf["inputs"]["specular"]  # a constant (folded) or a multiply node
    if isinstance(spec, dict):
        spec = graph["nodes"][spec["node"]]["inputs"]["a"] * graph["nodes"][spec["node"]]["inputs"]["b"]
    f0 = spec * ((ior - 1.0) / (ior + 1.0)) ** 2
    C.check(abs(f0 - 0.04) < 1e-4, "the 3.x Principled leaf's F0 %.4f = 0.08 x Specular (IOR %.2f)" % (f0, ior))


# Principled dielectrics of three roughnesses and colours, and a rough metal, lit by a sun alone.
SUNLIT = [
    ("SunWhite", (0.8, 0.8, 0.8), {"Roughness": 0.5}),
    ("SunRed", (0.8, 0.1, 0.05), {"Roughness": 0.3}),
    ("SunBlue", (0.1, 0.25, 0.7), {"Roughness": 0.8}),
    ("SunMetal", (0.9, 0.6, 0.3), {"Metallic": 1.0, "Roughness": 0.6}),
]


def test_principled_under_a_sun_matches_cycles():
    """Principled spheres (three dielectrics, a rough coloured metal) and a grey Principled
    floor (base 0.6, roughness 0.5) lit by a sun alone, no world: the floor within 2%, the
    spheres within 3%, the metal's rim within 4%. A uniform world cannot tell apart the ways of
    conserving energy that one light can, so the tests above could not:
    - Cycles dims the diffuse base by one minus the specular layer's albedo at the view
      direction only, with the real dielectric Fresnel curve; Prism's earlier reciprocal
      coupling with Schlick's curve made the floor 1.027 (Cycles' coupling with Schlick's
      curve: 1.012).
    - Cycles keeps a GGX lobe's multiple scattering in the lobe's shape; Prism's earlier
      cosine-shaped Kulla & Conty lobe made the metal's rim 1.057 / 1.052 / 1.021.
    Measured at 256 / 128 spp: floor 0.998, spheres 0.991-1.003, the metal's rim 0.989-0.999."""
    sc = scene(SUNLIT, sun=True)
    boxes = {name: pixel_box(sc, name) for name, _ in SPHERES}
    cpx = C.render_engine(sc, "cycles", QUICK_SPP[0], OUT, "sun", bounces=16)
    ppx = C.render_engine(sc, "prism", QUICK_SPP[1], OUT, "sun", bounces=16)
    c, p = means(cpx, boxes), means(ppx, boxes)
    slots = [(slot, mname, 0.03) for (slot, _), (mname, _, _) in zip(SPHERES, SUNLIT)]
    for slot, name, tol in slots + [("Floor", "Floor", 0.02)]:
        ratio = p[slot] / c[slot]
        C.check(all(abs(r - 1) < tol for r in ratio),
                "%s: mean Prism / Cycles %s within %d%% (Cycles %s)"
                % (name, ratio.round(4), round(tol * 100), c[slot].round(4)))
    # The metal's rim, away from its highlight: where multiple scattering shows most.
    ring = pixel_ring(sc, SPHERES[3][0])
    ratio = ppx[ring].mean(axis=0) / cpx[ring].mean(axis=0)
    C.check(all(abs(r - 1) < 0.04 for r in ratio),
            "SunMetal: rim (%d pixels) Prism / Cycles %s within 4%%" % (ring.sum(), ratio.round(4)))


def test_specular_tint_matches_cycles():
    """Specular Tint: the F82-tinted edges of two metals and the tinted F0 of two dielectrics
    (one with Specular IOR Level 0.8), within 3%."""
    if bpy.app.version < (4, 0, 0):
        return  # a colour from 4.0 on
    compare_principled("tint", TINTED, 0.03)


# Sheen (4.x): velvet-like dark bases under white and tinted sheens of three roughnesses, one
# over a coat.
SHEENED = [
    ("SheenVelvet", (0.3, 0.02, 0.05), {"Roughness": 0.8, "Sheen Weight": 1.0, "Sheen Roughness": 0.5}),
    ("SheenTint", (0.2, 0.2, 0.2), {"Roughness": 0.6, "Sheen Weight": 1.0, "Sheen Roughness": 0.3,
                                    "Sheen Tint": (0.9, 0.7, 0.3, 1.0)}),
    ("SheenRough", (0.02, 0.05, 0.3), {"Roughness": 0.5, "Sheen Weight": 0.7, "Sheen Roughness": 1.0}),
    ("SheenCoat", (0.5, 0.5, 0.5), {"Roughness": 0.5, "Sheen Weight": 1.0, "Sheen Roughness": 0.5,
                                    "Coat Weight": 1.0, "Coat Roughness": 0.1}),
]


def test_sheen_matches_cycles():
    """Principled Sheen over dark bases (where it shows most), tinted, rough (Sheen Roughness
    1, which no Charlie lobe reaches), and over a coat: sphere means within 3% of Cycles and the
    rims (where the sheen is brightest and the lobes' shapes differ most) within 5%. Prism's
    sheen is Cycles' model, the microfibre layer of Zeltner et al. 2022 (src/bsdf/
    fibre_sheen.rs, fitted by tools/sheen_ltc.rs to Prism's own simulation of the layer).
    Measured 0.995-1.00 (means) and 0.99-1.015 (rims); with the Charlie lobe of
    KHR_materials_sheen at the roughness of equal albedo the dark red velvet was 1.03 / 1.13 /
    1.09 and roughness 1 0.7x."""
    if bpy.app.version < (4, 0, 0):
        return  # Sheen Weight / Roughness / Tint are Blender 4.x inputs
    compare_principled("sheen", SHEENED, 0.03, rim_tol=0.05)


# Textured layers: (sphere, base colour, constant inputs, the input a Checker Texture drives,
# the checker's two colours).
TEXTURED = [
    ("CoatChecker", (0.05, 0.05, 0.05), {"Roughness": 0.6, "Coat Roughness": 0.05}, "Coat Weight",
     ((0.0, 0.0, 0.0, 1.0), (1.0, 1.0, 1.0, 1.0))),
    ("CoatRoughChecker", (0.05, 0.05, 0.05), {"Roughness": 0.6, "Coat Weight": 1.0}, "Coat Roughness",
     ((0.0, 0.0, 0.0, 1.0), (0.8, 0.8, 0.8, 1.0))),
    ("SheenChecker", (0.3, 0.02, 0.05), {"Roughness": 0.8, "Sheen Roughness": 0.5}, "Sheen Weight",
     ((0.0, 0.0, 0.0, 1.0), (1.0, 1.0, 1.0, 1.0))),
    ("SheenTintChecker", (0.05, 0.05, 0.05), {"Roughness": 0.8, "Sheen Weight": 1.0, "Sheen Roughness": 0.5},
     "Sheen Tint", ((1.0, 0.2, 0.1, 1.0), (0.1, 0.4, 1.0, 1.0))),
]


def test_textured_coat_and_sheen_match_cycles():
    """Coat Weight, Coat Roughness, Sheen Weight and Sheen Tint driven by a Checker Texture
    (Generated coordinates, scale 4): per-sphere means within 5% of Cycles; measured 0.986 /
    0.987 / 0.998-0.999 / 1.002.
    Without the graph's coat and sheen inputs the links are warned about and their socket
    values used (checked: the test then fails)."""
    if bpy.app.version < (4, 0, 0):
        return  # Coat / Sheen inputs of 4.x
    compare_textured("textured", TEXTURED, lambda name: 0.05)


# Specular Tint and Thin Film Thickness from a Checker Texture (the float input between the
# first entries of the two "colours").
TEXTURED_TINT_FILM = [
    ("TintChecker", (0.01, 0.01, 0.01), {"Roughness": 0.1}, "Specular Tint",
     ((0.1, 0.3, 1.0, 1.0), (0.3, 0.6, 1.0, 1.0))),
    ("FilmChecker", (0.05, 0.05, 0.05), {"Roughness": 0.2, "Thin Film IOR": 1.33}, "Thin Film Thickness",
     ((200.0, 0.0, 0.0, 1.0), (450.0, 0.0, 0.0, 1.0))),
    ("FilmMetalChecker", (0.95, 0.75, 0.35), {"Metallic": 1.0, "Roughness": 0.2, "Thin Film IOR": 1.45},
     "Thin Film Thickness", ((250.0, 0.0, 0.0, 1.0), (500.0, 0.0, 0.0, 1.0))),
    ("TintDielChecker", (0.05, 0.05, 0.05), {"Roughness": 0.2}, "Specular Tint",
     ((0.2, 0.6, 1.0, 1.0), (1.0, 0.8, 0.5, 1.0))),
]


def test_textured_tint_and_film_match_cycles():
    """Specular Tint (a metal's edge tint, a dielectric's F0 tint) and Thin Film Thickness (on a
    dielectric and a metal) driven by a Checker Texture: within 8% of Cycles (Cycles' thin film
    is Belcour & Barla's RGB approximation, Prism's the exact spectral Airy sum). Measured
    Prism / Cycles: 0.933 / 0.954 / 0.971 (the blue-tinted dark dielectric), 1.011 / 1.002 /
    1.018, 1.017 / 0.997 / 0.948, 0.989 / 0.989 / 0.991. Before, the links were warned about
    and their socket values used (the tinted sphere then grey: 3x Cycles' red)."""
    if bpy.app.version < (4, 2, 0):
        return  # Thin Film is a 4.2 input
    compare_textured("tintfilm", TEXTURED_TINT_FILM, lambda name: 0.08, spp=QUICK_SPP)


def compare_textured(label, table, tol, spp=(CYCLES_SPP, PRISM_SPP)):
    """Spheres of `table` (name, base colour, inputs, the input a Checker Texture drives, the
    checker's two colours) against Cycles, within tol(name) per channel."""
    spheres = [(name, color, inputs) for name, color, inputs, _, _ in table]
    sc = scene(spheres)
    for (name, _, _, socket, colors), (slot, _) in zip(table, SPHERES):
        mat = bpy.data.materials[name]
        nt = mat.node_tree
        bsdf = next(n for n in nt.nodes if n.type == "BSDF_PRINCIPLED")
        checker = nt.nodes.new("ShaderNodeTexChecker")
        checker.inputs["Scale"].default_value = 4.0
        checker.inputs["Color1"].default_value = colors[0]
        checker.inputs["Color2"].default_value = colors[1]
        colour = bsdf.inputs[socket].type == "RGBA"
        out = checker.outputs["Color"] if colour else checker.outputs["Fac"]
        if not colour:
            # Fac is 0 / 1; a float input between the two checker colours' first entries.
            math = nt.nodes.new("ShaderNodeMapRange")
            nt.links.new(checker.outputs["Fac"], math.inputs["Value"])
            math.inputs["To Min"].default_value = colors[0][0]
            math.inputs["To Max"].default_value = colors[1][0]
            out = math.outputs["Result"]
        nt.links.new(out, bsdf.inputs[socket])
    boxes = {name: pixel_box(sc, name) for name, _ in SPHERES}
    c = means(C.render_engine(sc, "cycles", spp[0], OUT, label, bounces=16), boxes)
    p = means(C.render_engine(sc, "prism", spp[1], OUT, label, bounces=16), boxes)
    prism = __import__("sys").modules["prism"]
    C.check(not prism.engine.LAST["warnings"], "no warnings: %s" % prism.engine.LAST["warnings"])
    for (slot, _), (mname, _, _, _, _) in zip(SPHERES, table):
        ratio = p[slot] / c[slot]
        C.check(all(abs(r - 1) < tol(mname) for r in ratio),
                "%s: mean Prism / Cycles %s within %d%% (Cycles %s)"
                % (mname, ratio.round(3), round(tol(mname) * 100), c[slot].round(4)))


def test_layers_in_mix_leaves_match_cycles():
    """Coat and Sheen on Principled BSDFs inside Mix Shaders (each leaf its own layers): a
    coated red Principled (Coat IOR 2.2) mixed 50/50 with a grey Diffuse, a sheened velvet mixed 70/30 with a
    Glossy, a coated metal with a sheened dielectric, and a plain Mix as control. Within 5%
    (measured 0.995-1.003; with the leaf's Coat IOR left at 1.5 the coated sphere was 0.87)."""
    if bpy.app.version < (4, 0, 0):
        return
    leaves = [
        ("MixCoat", 0.5, ("ShaderNodeBsdfPrincipled", (0.8, 0.1, 0.1), {"Roughness": 0.5, "Coat Weight": 1.0, "Coat IOR": 2.2,
                                                                       "Coat Roughness": 0.05}),
         ("ShaderNodeBsdfDiffuse", (0.5, 0.5, 0.5), {})),
        ("MixSheen", 0.3, ("ShaderNodeBsdfPrincipled", (0.3, 0.02, 0.05), {"Roughness": 0.8, "Sheen Weight": 1.0,
                                                                          "Sheen Roughness": 0.5}),
         ("ShaderNodeBsdfGlossy", (0.8, 0.8, 0.8), {"Roughness": 0.3})),
        ("MixBoth", 0.5, ("ShaderNodeBsdfPrincipled", (0.9, 0.9, 0.9), {"Metallic": 1.0, "Roughness": 0.4,
                                                                       "Coat Weight": 0.7, "Coat Roughness": 0.1,
                                                                       "Coat Tint": (0.9, 0.7, 0.4, 1.0)}),
         ("ShaderNodeBsdfPrincipled", (0.05, 0.1, 0.3), {"Roughness": 0.7, "Sheen Weight": 1.0, "Sheen Roughness": 0.4,
                                                        "Sheen Tint": (1.0, 0.8, 0.6, 1.0)})),
        ("MixPlain", 0.5, ("ShaderNodeBsdfPrincipled", (0.2, 0.5, 0.8), {"Roughness": 0.3}),
         ("ShaderNodeBsdfDiffuse", (0.8, 0.8, 0.2), {})),
    ]
    compare_mixes("mixlayers", leaves, lambda name: 0.05)


def test_tint_and_film_in_mix_leaves_match_cycles():
    """Specular Tint and Thin Film on Principled BSDFs inside Mix Shaders: a tinted metal and a
    tinted dark dielectric, a filmed dielectric and a filmed metal, each mixed with a Diffuse or
    a Glossy. Within 8% (Cycles' film is an RGB approximation); measured 0.97-1.005. Before,
    both were dropped with a warning."""
    if bpy.app.version < (4, 2, 0):
        return  # Thin Film is a 4.2 input
    leaves = [
        ("MixTintMetal", 0.5, ("ShaderNodeBsdfPrincipled", (0.9, 0.9, 0.9),
                               {"Metallic": 1.0, "Roughness": 0.3, "Specular Tint": (1.0, 0.4, 0.1, 1.0)}),
         ("ShaderNodeBsdfDiffuse", (0.5, 0.5, 0.5), {})),
        ("MixTintDiel", 0.8, ("ShaderNodeBsdfPrincipled", (0.01, 0.01, 0.01),
                              {"Roughness": 0.1, "Specular Tint": (0.1, 0.3, 1.0, 1.0)}),
         ("ShaderNodeBsdfDiffuse", (0.05, 0.05, 0.05), {})),
        ("MixFilm", 0.5, ("ShaderNodeBsdfPrincipled", (0.05, 0.05, 0.05),
                          {"Roughness": 0.2, "Thin Film Thickness": 400.0, "Thin Film IOR": 1.33}),
         ("ShaderNodeBsdfDiffuse", (0.5, 0.5, 0.5), {})),
        ("MixFilmMetal", 0.5, ("ShaderNodeBsdfPrincipled", (0.95, 0.75, 0.35),
                               {"Metallic": 1.0, "Roughness": 0.2, "Thin Film Thickness": 300.0,
                                "Thin Film IOR": 1.45}),
         ("ShaderNodeBsdfGlossy", (0.8, 0.8, 0.8), {"Roughness": 0.3})),
    ]
    compare_mixes("mixtintfilm", leaves, lambda name: 0.08, spp=QUICK_SPP)


def compare_mixes(label, leaves, tol, spp=(CYCLES_SPP, PRISM_SPP)):
    """Spheres whose materials are Mix Shaders of two shader nodes: `leaves` holds (name, fac,
    first, second), each leaf (node type, colour, inputs). Within tol(name) of Cycles."""
    sc = scene([(name, (0.5, 0.5, 0.5), {}) for name, _, _, _ in leaves])
    for name, fac, a, b in leaves:
        nt = bpy.data.materials[name].node_tree
        nt.nodes.clear()
        out = nt.nodes.new("ShaderNodeOutputMaterial")
        mix = nt.nodes.new("ShaderNodeMixShader")
        mix.inputs[0].default_value = fac
        for slot, (kind, color, inputs) in zip((1, 2), (a, b)):
            node = C.shader_node(nt, kind, color, **inputs)
            nt.links.new(node.outputs[0], mix.inputs[slot])
        nt.links.new(mix.outputs[0], out.inputs["Surface"])
    boxes = {name: pixel_box(sc, name) for name, _ in SPHERES}
    c = means(C.render_engine(sc, "cycles", spp[0], OUT, label, bounces=16), boxes)
    p = means(C.render_engine(sc, "prism", spp[1], OUT, label, bounces=16), boxes)
    prism = __import__("sys").modules["prism"]
    C.check(not prism.engine.LAST["warnings"], "no warnings: %s" % prism.engine.LAST["warnings"])
    for (slot, _), (mname, _, _, _) in zip(SPHERES, leaves):
        ratio = p[slot] / c[slot]
        C.check(all(abs(r - 1) < tol(mname) for r in ratio),
                "%s: mean Prism / Cycles %s within %d%% (Cycles %s)"
                % (mname, ratio.round(3), round(tol(mname) * 100), c[slot].round(4)))


def compare_principled(label, spheres, tol, spp=(CYCLES_SPP, PRISM_SPP), rim_tol=None):
    """Per-sphere means within `tol` of Cycles; with `rim_tol`, also the means over each
    sphere's rim (`pixel_ring`)."""
    sc = scene(spheres)
    boxes = {name: pixel_box(sc, name) for name, _ in SPHERES}
    cpx = C.render_engine(sc, "cycles", spp[0], OUT, label, bounces=16)
    ppx = C.render_engine(sc, "prism", spp[1], OUT, label, bounces=16)
    c, p = means(cpx, boxes), means(ppx, boxes)
    prism = __import__("sys").modules["prism"]
    C.check(not prism.engine.LAST["warnings"], "no warnings: %s" % prism.engine.LAST["warnings"])
    for (slot, _), (mname, _, _) in zip(SPHERES, spheres):
        ratio = p[slot] / c[slot]
        C.check(all(abs(r - 1) < tol for r in ratio),
                "%s: mean Prism / Cycles %s within %d%% (Cycles %s)"
                % (mname, ratio.round(3), round(tol * 100), c[slot].round(4)))
        if rim_tol is not None:
            ring = pixel_ring(sc, slot)
            ratio = ppx[ring].mean(axis=0) / cpx[ring].mean(axis=0)
            C.check(all(abs(r - 1) < rim_tol for r in ratio),
                    "%s: rim (%d pixels) Prism / Cycles %s within %d%%"
                    % (mname, ring.sum(), ratio.round(3), round(rim_tol * 100)))


def test_coat_over_bumped_base_matches_cycles():
    """A clear coat over a base bumped by a Noise texture keeps the surface's unperturbed
    normal (the coat's highlight stays sharp) unless Coat Normal is linked: a bumped dielectric
    and a bumped metal under a smooth coat, a smooth base under a coat bumped through Coat
    Normal (on a leaf of a Mix Shader, 80/20 with a grey Diffuse), and a base and coat bumped
    alike: means within 5% and the 3x3-blurred pixels'
    relMSE below 0.004 over each sphere. Measured at 256 / 128 spp: means 0.97-1.01, relMSE
    0.0009 / 0.0022 / 0.0013 / 0.0013 (at 512 / 256: 0.0006-0.0017; the Mix leaf's coat left
    unbumped: 0.0083); with the coat bumped along
    with the base (before) the bumped dielectric's relMSE was 0.0063 (the coat's highlight
    broken up where Cycles' stays sharp)."""
    if bpy.app.version < (4, 0, 0):
        return  # Coat Weight / Coat Normal are 4.x inputs
    spheres = [
        ("BumpCoat", (0.2, 0.3, 0.6), {"Roughness": 0.5, "Coat Weight": 1.0, "Coat Roughness": 0.03}),
        ("BumpCoatMetal", (0.9, 0.6, 0.3), {"Metallic": 1.0, "Roughness": 0.3, "Coat Weight": 1.0,
                                            "Coat Roughness": 0.05}),
        ("CoatNormal", (0.5, 0.1, 0.1), {"Roughness": 0.4, "Coat Weight": 1.0, "Coat Roughness": 0.03}),
        ("BumpBoth", (0.1, 0.5, 0.2), {"Roughness": 0.4, "Coat Weight": 1.0, "Coat Roughness": 0.03}),
    ]
    sc = scene(spheres)
    for name, _, _ in spheres:
        nt = bpy.data.materials[name].node_tree
        bsdf = next(n for n in nt.nodes if n.type == "BSDF_PRINCIPLED")
        bump = C.noise_bump(nt, scale=6.0, strength=0.7, distance=0.1)
        if name != "CoatNormal":
            nt.links.new(bump.outputs["Normal"], bsdf.inputs["Normal"])
        if name in ("CoatNormal", "BumpBoth"):
            nt.links.new(bump.outputs["Normal"], bsdf.inputs["Coat Normal"])
        if name == "CoatNormal":
            # On a leaf of a Mix Shader (with a little grey Diffuse): the graph's coat_normal.
            out = next(n for n in nt.nodes if n.type == "OUTPUT_MATERIAL")
            mix = nt.nodes.new("ShaderNodeMixShader")
            mix.inputs[0].default_value = 0.2
            diffuse = C.shader_node(nt, "ShaderNodeBsdfDiffuse", (0.5, 0.5, 0.5))
            nt.links.new(bsdf.outputs[0], mix.inputs[1])
            nt.links.new(diffuse.outputs[0], mix.inputs[2])
            nt.links.new(mix.outputs[0], out.inputs["Surface"])
    boxes = {name: pixel_box(sc, name, fraction=0.9) for name, _ in SPHERES}
    cy = C.render_engine(sc, "cycles", QUICK_SPP[0], OUT, "bumpcoat", bounces=16)
    pr = C.render_engine(sc, "prism", QUICK_SPP[1], OUT, "bumpcoat", bounces=16)
    c, p = means(cy, boxes), means(pr, boxes)
    prism = __import__("sys").modules["prism"]
    C.check(not prism.engine.LAST["warnings"], "no warnings: %s" % prism.engine.LAST["warnings"])
    for (slot, _), (mname, _, _) in zip(SPHERES, spheres):
        ratio = p[slot] / c[slot]
        rows, cols = boxes[slot]
        rel = C.rel_mse(C.blur(pr[rows, cols, :3]), C.blur(cy[rows, cols, :3]))
        C.check(all(abs(r - 1) < 0.05 for r in ratio) and rel < 0.004,
                "%s: mean Prism / Cycles %s within 5%%, blurred relMSE %.4f < 0.004 (Cycles %s)"
                % (mname, ratio.round(3), rel, c[slot].round(4)))


# Thin Film on metals (4.2+): a film over the conductor, whose complex IOR Prism (as Cycles)
# estimates from F0 and F82 (src/bsdf/metallic_roughness.rs `conductor_ior`).
FILMED_METALS = [
    ("FilmGold", (0.95, 0.75, 0.35), {"Metallic": 1.0, "Roughness": 0.2, "Thin Film Thickness": 300.0,
                                      "Thin Film IOR": 1.45}),
    ("FilmSteel", (0.6, 0.6, 0.6), {"Metallic": 1.0, "Roughness": 0.35, "Thin Film Thickness": 500.0,
                                    "Thin Film IOR": 1.6}),
    ("FilmHalf", (0.8, 0.4, 0.2), {"Metallic": 0.5, "Roughness": 0.3, "Thin Film Thickness": 400.0,
                                   "Thin Film IOR": 1.4}),
    ("FilmTinted", (0.9, 0.9, 0.9), {"Metallic": 1.0, "Roughness": 0.25, "Thin Film Thickness": 350.0,
                                     "Thin Film IOR": 1.5, "Specular Tint": (1.0, 0.5, 0.2, 1.0)}),
]


def test_thin_film_on_metals_matches_cycles():
    """Principled Thin Film on metallic spheres (gold, steel, half metallic, F82-tinted): the
    film's interference over the metal's complex IOR, exact per wavelength in Prism, Belcour &
    Barla's RGB approximation in Cycles. Measured Prism / Cycles: gold 0.953 / 1.010 / 0.961,
    steel 0.946 / 0.994 / 0.990, half metallic 1.016 / 0.988 / 0.977, tinted 0.976 / 1.000 /
    1.002; bound 8%. (Before, the film was left off the metallic part, with a warning.)"""
    if bpy.app.version < (4, 2, 0):
        return  # Thin Film is a 4.2 input
    compare_principled("filmmetal", FILMED_METALS, 0.08, spp=QUICK_SPP)


def test_thin_film_soap_bubbles():
    """scenes/soap_bubble (Principled Thin Film 250 / 420 / 700 nm, IOR 1.33, on IOR-1 shells,
    exported as KHR_materials_iridescence) at 40%: no warnings, and the 420 and 700 nm bubbles'
    mean colours within 5% of Cycles (measured 0.98-1.03). The 250 nm bubble is reported, not
    bounded: there Cycles' RGB approximation of the interference (Belcour & Barla 2017)
    departs from the exact spectral result (measured: Prism red 0.72-0.78 of Cycles; Prism's colour is
    the CIE integral of the Airy reflectance within 1%, tests/thin_film.rs)."""
    if bpy.app.version < (4, 2, 0):
        return  # Thin Film is a 4.2 input
    from bpy_extras.object_utils import world_to_camera_view
    from mathutils import Vector

    bpy.ops.wm.open_mainfile(filepath=os.path.join(C.REPO, "scenes", "soap_bubble", "soap_bubble.blend"))
    sc = bpy.context.scene
    sc.render.resolution_percentage = 100
    sc.render.resolution_x, sc.render.resolution_y = 192, 108
    bpy.context.view_layer.update()
    boxes = {}
    for ob in bpy.data.objects:
        if ob.name.startswith("Bubble"):
            c = world_to_camera_view(sc, sc.camera, ob.location)
            e = world_to_camera_view(sc, sc.camera, ob.location + Vector((ob.dimensions.x / 2, 0, 0)))
            r = abs(e.x - c.x) * 192 * 0.9
            boxes[ob.name] = (slice(int(c.y * 108 - r), int(c.y * 108 + r) + 1),
                              slice(int(c.x * 192 - r), int(c.x * 192 + r) + 1))
    c = means(C.render_engine(sc, "cycles", 512, OUT, "soap", bounces=16), boxes)
    p = means(C.render_engine(sc, "prism", 512, OUT, "soap", bounces=16), boxes)
    prism = sys.modules["prism"]
    C.check(not prism.engine.LAST["warnings"], "no warnings: %s" % prism.engine.LAST["warnings"])
    films = {ob.name: m.name for ob in bpy.data.objects if ob.name.startswith("Bubble") for m in ob.data.materials}
    for name in sorted(boxes):
        ratio = p[name] / c[name]
        msg = "%s (%s): mean Prism / Cycles %s (Cycles %s)" % (name, films[name], ratio.round(3), c[name].round(4))
        if films[name] == "Bubble250":
            print("  measured: " + msg, flush=True)
        else:
            C.check(all(abs(r - 1) < 0.05 for r in ratio), msg + " within 5%")


if __name__ == "__main__":
    from runner_util import run_tests

    C.enable_addon()
    C.prefs().binary_path = C.BINARY
    run_tests("bpy energy-conservation parity tests", globals())

"""Shader node graphs through the add-on, against Cycles, in the bpy wheel (Blender 5.0.1).

    .venv-bpy/bin/python tests/addon/test_node_graphs.py [TEST_NAME ...]

A grid of flat tiles seen from above by an orthographic camera, lit by a white world and a
sun from the side: each tile's image is its material's colour (diffuse) or its roughness
(the sun's glossy lobe), so every node setup shows up in the tile's mean and pattern. Each
tile is compared with Cycles (unbiased settings: no clamping, Filter Glossy 0, same bounces):
mean per channel within 10% and relMSE of the 3x3-blurred tile <= 0.03 (the issue's bounds).
"""

import math
import os
import sys
import tempfile

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import bpy  # noqa: E402
import numpy as np  # noqa: E402

import common as C  # noqa: E402

OUT = tempfile.mkdtemp(prefix="prism_addon_test_graph_")
prism = C.enable_addon()
C.prefs().binary_path = C.BINARY

from node_setups import (  # noqa: E402
    COLS,
    TILE_PX,
    tile_mesh,
    mix_material,
    new_material,
    build_scene,
)


def tile_pixels(img, i, rows):
    """The inner 70% of tile i (the image's rows run bottom-up in Blender's pixel order)."""
    h, w = img.shape[:2]
    r, c = divmod(i, COLS)
    cx = (c + 0.5) * w / COLS
    # From the tile's world y (build_scene) through the orthographic view's scale: the image
    # height is rounded to whole pixels, so rows are not exactly h / rows apart.
    px_per_unit = w / (COLS * 1.2)
    cy = h / 2 + ((rows - 1) * 0.6 - r * 1.2) * px_per_unit
    half = 0.35 * TILE_PX
    return img[int(cy - half):int(cy + half), int(cx - half):int(cx + half)]


def test_node_setups_match_cycles():
    spp = 128
    sc, tiles, rows = build_scene()
    cy = C.render_engine(sc, "cycles", spp, OUT, "graphs", 4)
    sc, tiles, rows = build_scene()
    pr = C.render_engine(sc, "prism", spp, OUT, "graphs", 4)
    warnings = prism.engine.LAST["warnings"]
    failures = []
    for i, (name, _) in enumerate(tiles):
        a, b = tile_pixels(pr, i, rows), tile_pixels(cy, i, rows)
        ma, mb = a.mean(axis=(0, 1)), b.mean(axis=(0, 1))
        rel = C.rel_mse(C.blur(a), C.blur(b))
        # Within 10% per channel (absolutely for channels near 0).
        ok = bool(np.all(np.abs(ma - mb) <= 0.10 * np.maximum(mb, 0.02))) and rel <= 0.03
        if name in {"BumpNoise", "BumpWide", "MixBump", "NormalMapGraph", "NormalMapObject"}:
            # The bump pattern itself (a flat tile would match the means too).
            la, lb = a.mean(axis=-1).ravel(), b.mean(axis=-1).ravel()
            corr = float(np.corrcoef(la, lb)[0, 1])
            print("  " + name + ": pattern std %.4f (Cycles %.4f), correlation %.3f" % (la.std(), lb.std(), corr))
            # With the bump offsets along Cycles' basis and its filter width (1 pixel before
            # Blender 4.5) the patterns agree: 0.993-0.999 in 3.4 and 5.0 (0.88 in 3.4 and 0.18
            # for BumpWide with offsets along the triangle's edges at 0.1 pixel).
            min_corr = 0.97
            ok = ok and lb.std() > 0.01 and corr > min_corr
        print("  %-15s prism %s cycles %s relMSE %.4f %s" % (name, np.round(ma, 3), np.round(mb, 3), rel, "" if ok else "FAIL"))
        if not ok:
            failures.append(name)
    C.check(not failures, "every tile within 10%% per channel and relMSE <= 0.03 (failed: %s)" % failures)
    C.check(not warnings, "no warnings: %s" % warnings)


# Tiles whose texture is piecewise constant (per-pixel comparison inside the pieces).
DISCONTINUOUS = {"VoronoiF1", "WhiteNoiseCells", "Brick"}


def noise_tiles():
    """Emission tiles showing procedural textures (the value itself, no lighting)."""
    out = []

    def tile(name, build):
        mat, nt, sh = new_material(name, "ShaderNodeEmission")
        sock = build(nt)
        nt.links.new(sock, sh.inputs["Color"])
        out.append((name, mat))

    def noise(nt, dims="3D", kind="FBM", output="Fac", **inputs):
        n = nt.nodes.new("ShaderNodeTexNoise")
        n.noise_dimensions = dims
        if hasattr(n, "noise_type"):
            n.noise_type = kind
        for k, v in inputs.items():
            n.inputs[k].default_value = v
        return n.outputs[output]

    tile("NoiseFbm3D", lambda nt: noise(nt, Scale=4.0, Detail=2.0, Roughness=0.5))
    tile("NoiseColor2D", lambda nt: noise(nt, "2D", output="Color", Scale=3.0, Detail=3.5, Roughness=0.6, Distortion=0.4))
    tile("NoiseRidged4D", lambda nt: noise(nt, "4D", "RIDGED_MULTIFRACTAL", Scale=2.0, Detail=4.0, W=0.7, Offset=1.0, Gain=2.0))
    tile("NoiseHetero1D", lambda nt: noise(nt, "1D", "HETERO_TERRAIN", Scale=3.0, Detail=2.5, W=1.3, Offset=0.5))

    def cells(nt):
        # White noise of cell indices: constant per cell, so both renderers hash equal keys.
        tc = nt.nodes.new("ShaderNodeTexCoord")
        vm = nt.nodes.new("ShaderNodeVectorMath")
        vm.operation = "SCALE"
        vm.inputs["Scale"].default_value = 4.0
        # Off the cell boundaries: a flat tile's generated z is 0.5, and 4 x 0.5 = 2 would
        # round either way.
        add = nt.nodes.new("ShaderNodeVectorMath")
        add.operation = "ADD"
        add.inputs[1].default_value = (0.13, 0.13, 0.13)
        fl = nt.nodes.new("ShaderNodeVectorMath")
        fl.operation = "FLOOR"
        wn = nt.nodes.new("ShaderNodeTexWhiteNoise")
        nt.links.new(tc.outputs["Generated"], vm.inputs[0])
        nt.links.new(vm.outputs["Vector"], add.inputs[0])
        nt.links.new(add.outputs["Vector"], fl.inputs[0])
        nt.links.new(fl.outputs["Vector"], wn.inputs["Vector"])
        return wn.outputs["Color"]

    tile("WhiteNoiseCells", cells)

    def voronoi(nt, dims="3D", feature="F1", metric="EUCLIDEAN", output="Distance", **inputs):
        n = nt.nodes.new("ShaderNodeTexVoronoi")
        n.voronoi_dimensions = dims
        n.feature = feature
        n.distance = metric
        for k, v in inputs.items():
            n.inputs[k].default_value = v
        return n.outputs[output]

    tile("VoronoiF1", lambda nt: voronoi(nt, output="Color", Scale=4.0))
    tile("VoronoiF2Manhattan", lambda nt: voronoi(nt, "2D", "F2", "MANHATTAN", Scale=3.0, Detail=1.5, Randomness=0.8))
    tile("VoronoiSmooth", lambda nt: voronoi(nt, "3D", "SMOOTH_F1", Scale=4.0, Smoothness=0.6))
    tile("VoronoiEdge4D", lambda nt: voronoi(nt, "4D", "DISTANCE_TO_EDGE", Scale=3.0, W=0.3))
    tile("VoronoiMinkowski", lambda nt: voronoi(nt, "3D", "F1", "MINKOWSKI", Scale=3.0, Exponent=1.5))

    def wave(nt, **kw):
        n = nt.nodes.new("ShaderNodeTexWave")
        for k in ("wave_type", "bands_direction", "rings_direction", "wave_profile"):
            if k in kw:
                setattr(n, k, kw.pop(k))
        for k, v in kw.items():
            n.inputs[k].default_value = v
        return n.outputs["Fac"]

    tile("WaveBandsSin", lambda nt: wave(nt, Scale=2.0))
    tile("WaveRingsSaw", lambda nt: wave(nt, wave_type="RINGS", rings_direction="SPHERICAL", wave_profile="TRI",
                                         Scale=1.5, Distortion=3.0, Detail=3.0))

    def magic(nt):
        n = nt.nodes.new("ShaderNodeTexMagic")
        n.turbulence_depth = 4
        n.inputs["Distortion"].default_value = 1.7
        n.inputs["Scale"].default_value = 1.5
        return n.outputs["Color"]

    tile("Magic", magic)

    def blackbody(nt):
        # 1000 K to 10000 K across the tile.
        bb = nt.nodes.new("ShaderNodeBlackbody")
        nt.links.new(C.generated_x_range(nt, 1000.0, 10000.0), bb.inputs[0])
        return bb.outputs[0]

    tile("Blackbody", blackbody)

    def brick(nt):
        n = nt.nodes.new("ShaderNodeTexBrick")
        n.offset = 0.3
        n.squash = 0.7
        n.inputs["Scale"].default_value = 1.0
        n.inputs["Mortar Smooth"].default_value = 0.0
        n.inputs["Mortar Size"].default_value = 0.04
        return n.outputs["Color"]

    tile("Brick", brick)
    return out


def tile_row_scene(make_tiles):
    """A fresh scene with the (name, material) tiles of `make_tiles()` in a row, 40 px each,
    over a black world, seen from above by an orthographic camera: (scene, tiles)."""
    C.reset()
    sc = bpy.context.scene
    tiles = make_tiles()
    for i, (name, mat) in enumerate(tiles):
        C.mesh_object(name, tile_mesh, mat, location=(i * 1.2 - (len(tiles) - 1) * 0.6, 0.0, 0.0))
    C.world((0.0, 0.0, 0.0), 0.0)
    cam = C.camera((0.0, 0.0, 5.0), (0.0, 0.0, 0.0))
    cam.data.type = "ORTHO"
    cam.data.ortho_scale = len(tiles) * 1.2
    sc.render.resolution_x = len(tiles) * 40
    sc.render.resolution_y = 40
    sc.render.resolution_percentage = 100
    return sc, tiles


def test_noise_textures_match_cycles():
    """Noise (fBM, ridged, hetero terrain; 1D-4D, distortion, colour) and White Noise on emission
    tiles: per-pixel error against Cycles within 1% of the range (the 99.5th percentile, tile
    interiors; pixel averages over the same footprint)."""
    spp = 256
    results = []
    for engine in ("cycles", "prism"):
        sc, tiles = tile_row_scene(noise_tiles)
        results.append(C.render_engine(sc, engine, spp, OUT, "noise", 2))
    cy, pr = results
    C.check(not prism.engine.LAST["warnings"], "no warnings: %s" % prism.engine.LAST["warnings"])
    failures = []
    for i, (name, _) in enumerate(tiles):
        x0 = int((i + 0.5) * 40 - 14)
        a, b = pr[6:34, x0:x0 + 28], cy[6:34, x0:x0 + 28]
        # The texture's range over the tile (at least 0.1: a constant tile is judged absolutely).
        rng = max(float(b.max() - b.min()), 0.1)
        err = np.abs(a - b)
        if name in DISCONTINUOUS:
            # Cell colours jump at cell borders, where a pixel's value is the (noisy) fraction
            # of its samples on each side: compare cell interiors (pixels whose 3x3
            # neighbourhood is uniform in Cycles' image); the mean covers the borders.
            h, w = b.shape[:2]
            flat = np.zeros((h, w), bool)
            win = np.stack([b[1 + dy:h - 1 + dy, 1 + dx:w - 1 + dx] for dy in (-1, 0, 1) for dx in (-1, 0, 1)])
            flat[1:-1, 1:-1] = (win.max(axis=0) - win.min(axis=0)).max(axis=-1) < 0.01 * rng
            C.check(flat.mean() > 0.2, "%s: a fifth of the pixels or more are cell interiors (%.2f)" % (name, flat.mean()))
            C.check(np.all(np.abs(a.mean(axis=(0, 1)) - b.mean(axis=(0, 1))) < 0.01 * rng), "%s: means within 1%%" % name)
            err = err[flat]
        p995 = float(np.percentile(err, 99.5)) / rng
        print("  %-16s mean %s vs %s  range %.3f  error / range: mean %.4f  99.5%% %.4f  max %.4f"
              % (name, np.round(a.mean(axis=(0, 1)), 3), np.round(b.mean(axis=(0, 1)), 3), rng,
                 err.mean() / rng, p995, err.max() / rng))
        if p995 > 0.01:
            failures.append(name)
    C.check(not failures, "per-pixel error within 1%% of the range (failed: %s)" % failures)


def refraction_scene():
    """The classic node glass (Refraction and Glossy BSDFs mixed by a Fresnel node) as a
    sphere in front of an emissive checker backdrop; world black, no other light."""
    C.reset()
    sc = bpy.context.scene
    mat, nt, rf, gl, mx = mix_material("FresnelGlass", "ShaderNodeBsdfRefraction", "ShaderNodeBsdfGlossy")
    rf.inputs["Color"].default_value = (0.7, 0.9, 0.8, 1.0)
    rf.inputs["Roughness"].default_value = 0.1
    rf.inputs["IOR"].default_value = 1.45
    gl.inputs["Roughness"].default_value = 0.1
    fr = nt.nodes.new("ShaderNodeFresnel")
    fr.inputs["IOR"].default_value = 1.45
    nt.links.new(fr.outputs["Fac"], mx.inputs["Fac"])
    C.mesh_object("Glass", C.sphere(1.0), mat, smooth=True)

    back, bnt, em = new_material("Backdrop", "ShaderNodeEmission")
    chk = bnt.nodes.new("ShaderNodeTexChecker")
    chk.inputs["Scale"].default_value = 6.0
    chk.inputs["Color1"].default_value = (1.0, 1.0, 1.0, 1.0)
    chk.inputs["Color2"].default_value = (0.1, 0.1, 0.1, 1.0)
    bnt.links.new(chk.outputs["Color"], em.inputs["Color"])
    C.mesh_object("Backdrop", C.plane(8.0), back, location=(0.0, 3.0, 0.0), rotation=(math.pi / 2, 0.0, 0.0))
    C.world((0.0, 0.0, 0.0), 0.0)
    C.camera((0.0, -5.0, 0.0), (0.0, 0.0, 0.0))
    sc.render.resolution_x = 96
    sc.render.resolution_y = 96
    sc.render.resolution_percentage = 100
    return sc


def test_refraction_bsdf_matches_cycles():
    """Blender's Refraction BSDF is the dielectric's refraction alone (no Fresnel term; the
    node setup mixes in reflection by a Fresnel factor): the sphere's pixels (the checker
    bent and tinted twice, plus the reflected backdrop) against Cycles', 8 bounces."""
    spp = 128
    cy = C.render_engine(refraction_scene(), "cycles", spp, OUT, "refraction", 8)
    pr = C.render_engine(refraction_scene(), "prism", spp, OUT, "refraction", 8)
    C.check(not prism.engine.LAST["warnings"], "no warnings: %s" % prism.engine.LAST["warnings"])
    h, w = cy.shape[:2]
    yy, xx = np.mgrid[0:h, 0:w]
    # The sphere's disc (radius 1 at distance 5, 50 mm lens on a 36 mm sensor), inner 85%.
    r_px = w / 2 * (1.0 / math.sqrt(24.0)) / (36.0 / 2 / 50.0) * 0.85
    disc = (xx - w / 2 + 0.5) ** 2 + (yy - h / 2 + 0.5) ** 2 < r_px ** 2
    ma, mb = pr[disc].mean(axis=0), cy[disc].mean(axis=0)
    inner = disc[1:-1, 1:-1]  # C.blur trims a pixel at each border
    rel = C.rel_mse(C.blur(pr)[inner], C.blur(cy)[inner])
    print("  refraction glass: prism %s cycles %s blurred relMSE %.4f" % (np.round(ma, 4), np.round(mb, 4), rel))
    C.check(bool(np.all(np.abs(ma - mb) <= 0.05 * mb)), "sphere means within 5% per channel")
    C.check(rel <= 0.02, "blurred relMSE <= 0.02")


def render_tile(sc, mat, name):
    """One tile of material `mat` under a white world, seen from above, rendered by Prism at
    16 x 16 and 4 spp: its RGB pixels."""
    C.mesh_object("Tile", tile_mesh, mat)
    C.world((1.0, 1.0, 1.0), 1.0)
    cam = C.camera((0.0, 0.0, 5.0), (0.0, 0.0, 0.0))
    cam.data.type = "ORTHO"
    cam.data.ortho_scale = 0.8
    sc.render.resolution_x = sc.render.resolution_y = 16
    C.use_prism(sc, spp=4)
    return C.render_pixels(sc, os.path.join(OUT, name + ".exr"))[..., :3]


def test_unsupported_nodes_are_named():
    """A node Prism cannot evaluate yet is one warning naming material, node and type, shown in
    the status bar (RenderEngine.report); with baking off, the input falls back to its own
    value."""
    C.reset()
    sc = bpy.context.scene
    sc.prism.bake_unsupported_nodes = False
    mat, nt, sh = new_material("Wavy")
    wave = nt.nodes.new("ShaderNodeTexGabor" if hasattr(bpy.types, "ShaderNodeTexGabor") else "ShaderNodeBlackbody")
    wave.name = "MyWaves"
    nt.links.new(wave.outputs[0], sh.inputs["Color"])
    sh.inputs["Color"].default_value = (0.2, 0.7, 0.2, 1.0)
    px = render_tile(sc, mat, "wavy")
    warnings = prism.engine.LAST["warnings"]
    named = [w for w in warnings if "Wavy" in w and "MyWaves" in w and wave.bl_idname in w]
    C.check(len(named) == 1, "one warning names material, node and type: %s" % warnings)
    m = px.mean(axis=(0, 1))
    C.check(m[1] > 2.0 * m[0], "the Color input's own value (green) is used: %s" % m)


def _unsupported_texture(nt):
    """A texture node Prism does not evaluate: 5.0's Gabor, 3.x's Musgrave (signed values)."""
    if hasattr(bpy.types, "ShaderNodeTexGabor"):
        n = nt.nodes.new("ShaderNodeTexGabor")
        n.inputs["Scale"].default_value = 5.0
    else:
        n = nt.nodes.new("ShaderNodeTexMusgrave")
        n.inputs["Scale"].default_value = 3.0
    return n


def baked_tiles():
    """Emission tiles whose colour comes through a node Prism cannot evaluate, and so is baked
    by Cycles: (name, material). Nodes after the baked one stay live in Prism's graph."""
    out = []
    # The node alone, then a Math node of Prism's (|x|: Musgrave is signed).
    mat, nt, em = new_material("BakedTexture", "ShaderNodeEmission")
    tex = _unsupported_texture(nt)
    tex.name = "Unsupported"
    ab = nt.nodes.new("ShaderNodeMath")
    ab.operation = "ABSOLUTE"
    nt.links.new(tex.outputs[0], ab.inputs[0])
    nt.links.new(ab.outputs[0], em.inputs["Color"])
    out.append(("BakedTexture", mat))
    # Inside a node group, with a Color Ramp after it there: the group's output is baked.
    grp, _, gout = C.node_group("UnsupportedGroup", outputs=[("Color", "NodeSocketColor")])
    gtex = _unsupported_texture(grp)
    ramp = grp.nodes.new("ShaderNodeValToRGB")
    ramp.color_ramp.elements[0].color = (0.9, 0.2, 0.1, 1.0)
    ramp.color_ramp.elements[1].color = (0.1, 0.3, 0.9, 1.0)
    grp.links.new(gtex.outputs[0], ramp.inputs["Fac"])
    grp.links.new(ramp.outputs["Color"], gout.inputs[0])
    mat, nt, em = new_material("BakedGroup", "ShaderNodeEmission")
    g = nt.nodes.new("ShaderNodeGroup")
    g.node_tree = grp
    nt.links.new(g.outputs[0], em.inputs["Color"])
    out.append(("BakedGroup", mat))
    # A baked vector (Vector Rotate of Generated coordinates: signed values) into a live
    # Checker: the squares' edges land where Cycles draws them.
    mat, nt, em = new_material("BakedVector", "ShaderNodeEmission")
    tc = nt.nodes.new("ShaderNodeTexCoord")
    rot = nt.nodes.new("ShaderNodeVectorRotate")
    rot.rotation_type = "Z_AXIS"
    rot.inputs["Angle"].default_value = math.radians(30.0)
    chk = nt.nodes.new("ShaderNodeTexChecker")
    chk.inputs["Scale"].default_value = 3.0
    nt.links.new(tc.outputs["Generated"], rot.inputs["Vector"])
    nt.links.new(rot.outputs["Vector"], chk.inputs["Vector"])
    nt.links.new(chk.outputs["Color"], em.inputs["Color"])
    out.append(("BakedVector", mat))
    return out


def _baked_scene():
    sc, tiles = tile_row_scene(baked_tiles)
    sc.prism.bake_resolution = "256"
    return sc, tiles


def test_unsupported_nodes_are_baked():
    """Nodes Prism cannot evaluate are baked by Cycles into textures on the mesh's UV map (at
    top level, inside a group, a vector into a live Checker): each tile against Cycles, mean
    within 2% and the 99.5th percentile of the 3x3-blurred per-pixel error within 3% of the
    tile's range.
    The warning names the node and says it is baked; a second render takes the bakes from the
    cache. A mesh without a UV map, and a node fed by view-dependent coordinates, are not baked:
    warned, the input's own value."""
    spp = 256
    results = []
    for engine in ("cycles", "prism"):
        sc, tiles = _baked_scene()
        results.append(C.render_engine(sc, engine, spp, OUT, "baked", 2))
    cy, pr = results
    warnings = prism.engine.LAST["warnings"]
    stats = prism.engine.LAST["bake"]
    tiles = [(name, None) for name, _ in tiles]
    C.check(stats is not None and stats["baked"] + stats["cached"] == len(tiles), "one bake per tile: %s" % stats)
    for name, _ in tiles:
        C.check(any(name in w and "baked with Cycles" in w for w in warnings), "%s: the warning says it is baked: %s"
                % (name, warnings))
    failures = []
    for i, (name, _) in enumerate(tiles):
        x0 = int((i + 0.5) * 40 - 14)
        a, b = pr[6:34, x0:x0 + 28], cy[6:34, x0:x0 + 28]
        rng = max(float(b.max() - b.min()), 0.1)
        ma, mb = a.mean(axis=(0, 1)), b.mean(axis=(0, 1))
        # 3x3-blurred: the Checker's edge pixels are fractions of their samples, noisy in both
        # renders; an edge one pixel off still shows as about a third of the range.
        p995 = float(np.percentile(np.abs(C.blur(a) - C.blur(b)), 99.5)) / rng
        print("  %-13s mean %s vs %s  range %.3f  99.5%% error / range %.4f" % (name, np.round(ma, 3), np.round(mb, 3), rng, p995))
        if not (np.all(np.abs(ma - mb) <= 0.02 * np.maximum(mb, 0.05)) and p995 <= 0.03):
            failures.append(name)
    C.check(not failures, "baked tiles match Cycles (failed: %s)" % failures)

    # Again: every bake from the cache.
    sc, _ = _baked_scene()
    again = C.render_engine(sc, "prism", spp, OUT, "baked_again", 2)
    stats = prism.engine.LAST["bake"]
    C.check(stats["cached"] == len(tiles) and stats["baked"] == 0, "the second render bakes nothing: %s" % stats)
    C.check(C.rel_mse(again, pr) < 1e-3, "and renders the same image")

    # No UV map: warned, the input's own value (green); view-dependent input: not baked.
    C.reset()
    sc = bpy.context.scene
    mat, nt, em = new_material("NoUvs", "ShaderNodeEmission")
    em.inputs["Color"].default_value = (0.1, 0.8, 0.1, 1.0)
    nt.links.new(_unsupported_texture(nt).outputs[0], em.inputs["Color"])
    C.mesh_object("NoUvTile", C.plane(1.0), mat)
    mat2, nt2, em2 = new_material("ViewDependent", "ShaderNodeEmission")
    tc = nt2.nodes.new("ShaderNodeTexCoord")
    rot = nt2.nodes.new("ShaderNodeVectorRotate")
    rot.name = "Spin"
    nt2.links.new(tc.outputs["Reflection"], rot.inputs["Vector"])
    nt2.links.new(rot.outputs["Vector"], em2.inputs["Color"])
    C.mesh_object("ReflTile", tile_mesh, mat2, location=(2.0, 0.0, 0.0))
    # A group with a view-dependent node inside beside the unsupported one: not baked whole.
    grp, _, gout = C.node_group("FacingGroup", outputs=[("Value", "NodeSocketFloat")])
    lw = grp.nodes.new("ShaderNodeLayerWeight")
    gmul = grp.nodes.new("ShaderNodeMath")
    gmul.operation = "MULTIPLY"
    grp.links.new(lw.outputs["Facing"], gmul.inputs[0])
    grp.links.new(_unsupported_texture(grp).outputs[0], gmul.inputs[1])
    grp.links.new(gmul.outputs[0], gout.inputs[0])
    mat3, nt3, em3 = new_material("FacingInGroup", "ShaderNodeEmission")
    g3 = nt3.nodes.new("ShaderNodeGroup")
    g3.node_tree = grp
    g3.name = "Facing"
    nt3.links.new(g3.outputs[0], em3.inputs["Strength"])
    C.mesh_object("FacingTile", tile_mesh, mat3, location=(4.0, 0.0, 0.0))
    C.world((0.0, 0.0, 0.0), 0.0)
    cam = C.camera((0.0, 0.0, 5.0), (0.0, 0.0, 0.0))
    cam.data.type = "ORTHO"
    cam.data.ortho_scale = 1.0
    sc.render.resolution_x = sc.render.resolution_y = 16
    px = C.render_engine(sc, "prism", 4, OUT, "no_uvs", 2)
    warnings = prism.engine.LAST["warnings"]
    C.check(any("NoUvs" in w and "no UV map" in w for w in warnings), "a mesh without UVs is warned: %s" % warnings)
    C.check(any("ViewDependent" in w and "Spin" in w and "cannot be baked" in w for w in warnings),
            "a node fed by Reflection coordinates is not baked: %s" % warnings)
    C.check(any("FacingInGroup" in w and "Facing" in w and "cannot be baked" in w for w in warnings),
            "a group with a Layer Weight inside is not baked: %s" % warnings)
    m = px.mean(axis=(0, 1))
    C.check(m[1] > 4.0 * m[0], "no UVs: the Color input's own value (green): %s" % m)


def test_baked_bevel_normal_matches_cycles():
    """A Bevel node on a diffuse cube's Normal (the hard-surface staple) is baked by Cycles into
    a world-space normal texture that feeds the graph's `normal`: 3x3-blurred relMSE against
    Cycles <= 1e-4 (measured 1.1e-5 at 512 px, 64 x 64; the unbevelled cube is 4.2e-3 away)."""
    def cube_scene(bevel):
        C.reset()
        sc = bpy.context.scene
        mat, nt, sh = new_material("Bevelled", "ShaderNodeBsdfDiffuse")
        sh.inputs["Color"].default_value = (0.8, 0.8, 0.8, 1.0)
        if bevel:
            b = nt.nodes.new("ShaderNodeBevel")
            b.inputs["Radius"].default_value = 0.2
            b.samples = 16
            nt.links.new(b.outputs["Normal"], sh.inputs["Normal"])
        bpy.ops.mesh.primitive_cube_add(size=1.5, rotation=(0.6, 0.3, 0.8))
        bpy.context.active_object.data.materials.append(mat)
        C.world((0.2, 0.2, 0.2), 1.0)
        C.light("Sun", "SUN", 3.0, (0, 0, 5), rotation=(0.5, 0.3, 0.2), angle=0.0)
        C.camera((0.0, -5.0, 0.0), (0.0, 0.0, 0.0))
        sc.render.resolution_x = sc.render.resolution_y = 64
        sc.render.resolution_percentage = 100
        sc.prism.bake_resolution = "512"
        return sc

    cy = C.render_engine(cube_scene(True), "cycles", 64, OUT, "bevel", 4)
    pr = C.render_engine(cube_scene(True), "prism", 64, OUT, "bevel", 4)
    warnings = prism.engine.LAST["warnings"]
    C.check(any("Bevel" in w and "baked with Cycles" in w for w in warnings), "the Bevel is baked: %s" % warnings)
    flat = C.render_engine(cube_scene(False), "prism", 64, OUT, "bevel_off", 4)
    rel, rel_flat = C.rel_mse(C.blur(pr), C.blur(cy)), C.rel_mse(C.blur(flat), C.blur(cy))
    print("  bevel: blurred relMSE %.2e (without the bevel %.2e)" % (rel, rel_flat))
    C.check(rel <= 1e-4 and rel_flat > 1e-3, "bevelled like Cycles (%.2e; unbevelled %.2e)" % (rel, rel_flat))


def test_mix_leaves_with_different_normals_are_warned():
    """Leaves of a Mix Shader whose Normal inputs come from different sources (here one bumped,
    one not) cannot share the material's one shading normal: a warning names the leaf."""
    C.reset()
    sc = bpy.context.scene
    mat, nt, df, gl, mx = mix_material("HalfBumped", "ShaderNodeBsdfDiffuse", "ShaderNodeBsdfGlossy")
    bump = nt.nodes.new("ShaderNodeBump")
    nz = nt.nodes.new("ShaderNodeTexNoise")
    nt.links.new(nz.outputs["Fac"], bump.inputs["Height"])
    nt.links.new(bump.outputs["Normal"], gl.inputs["Normal"])
    render_tile(sc, mat, "half_bumped")
    warnings = prism.engine.LAST["warnings"]
    named = [w for w in warnings if "HalfBumped" in w and gl.name in w and "Normal" in w]
    C.check(len(named) == 1, "one warning names the material and the bumped leaf: %s" % warnings)


if __name__ == "__main__":
    # Test names: after "--" under `blender -b ... --python`, else the script's arguments.
    argv = sys.argv
    names = argv[argv.index("--") + 1:] if "--" in argv else ([] if "--python" in argv else argv[1:])
    names = names or [n for n in sorted(globals()) if n.startswith("test_")]
    for n in names:
        print(n, flush=True)
        globals()[n]()
    print("all node graph tests passed")

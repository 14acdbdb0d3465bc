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
import bmesh  # noqa: E402
import numpy as np  # noqa: E402

import common as C  # noqa: E402

OUT = tempfile.mkdtemp(prefix="prism_addon_test_graph_")
prism = C.enable_addon()
C.prefs().binary_path = C.BINARY

COLS = 6  # the image stays wider than tall: an orthographic scale spans the larger side
TILE_PX = 24


def ident(sockets, identifier):
    """A socket by identifier (the Mix node's A/B/Factor/Result exist once per data type)."""
    return next(x for x in sockets if x.identifier == identifier)


def tile_mesh(bm):
    uv = bm.loops.layers.uv.new("UVMap")
    bmesh.ops.create_grid(bm, x_segments=1, y_segments=1, size=0.5, calc_uvs=True)
    # A second UV map, rotated a quarter turn, for the UV Map node.
    alt = bm.loops.layers.uv.new("Rotated")
    col = bm.loops.layers.color.new("Paint") if hasattr(bm.loops.layers, "color") else None
    for f in bm.faces:
        for loop in f.loops:
            u, v = loop[uv].uv
            loop[alt].uv = (v, 1.0 - u)
            if col is not None:
                p = loop.vert.co
                loop[col] = (0.5 + p.x, 0.5 + p.y, 0.2, 1.0)


def image(name, w, h, fn, non_color=False):
    img = bpy.data.images.new(name, w, h, alpha=True)
    # The colour space first: changing it regenerates a generated image's pixels.
    if non_color:
        img.colorspace_settings.name = "Non-Color"
    px = np.zeros((h, w, 4), np.float32)
    for y in range(h):
        for x in range(w):
            px[y, x] = fn(x, y)
    img.pixels = px.reshape(-1)
    assert abs(img.pixels[0] - px[0, 0, 0]) < 0.01, "image pixels kept"
    return img


def mix_material(name, first, second, fac=0.5):
    """A material whose surface is a Mix Shader of two new shader nodes (types `first`,
    `second`): (material, node tree, first node, second node, mix node)."""
    mat = bpy.data.materials.new(name)
    mat.use_nodes = True
    nt = mat.node_tree
    nt.nodes.clear()
    outn = nt.nodes.new("ShaderNodeOutputMaterial")
    a, b = nt.nodes.new(first), nt.nodes.new(second)
    mx = nt.nodes.new("ShaderNodeMixShader")
    mx.inputs["Fac"].default_value = fac
    nt.links.new(a.outputs[0], mx.inputs[1])
    nt.links.new(b.outputs[0], mx.inputs[2])
    nt.links.new(mx.outputs[0], outn.inputs["Surface"])
    return mat, nt, a, b, mx


def new_material(name, shader="ShaderNodeBsdfDiffuse"):
    mat = bpy.data.materials.new(name)
    mat.use_nodes = True
    nt = mat.node_tree
    nt.nodes.clear()
    out = nt.nodes.new("ShaderNodeOutputMaterial")
    sh = nt.nodes.new(shader)
    nt.links.new(sh.outputs[0], out.inputs["Surface"])
    return mat, nt, sh


def setups():
    """(name, material) for every tile; each builds one everyday node setup."""
    out = []
    stripes = image("Stripes", 8, 8, lambda x, y: (0.9, 0.5, 0.1, 1.0) if (x // 2) % 2 else (0.1, 0.3, 0.8, 1.0))
    # Roughness 0.1 / 0.35: where single- and multiple-scattering GGX (Cycles' default) agree
    # within ~2% (the energy lost at high roughness is issue 14's).
    rough = image("RoughStripes", 8, 8, lambda x, y: (0.1, 0.1, 0.1, 1.0) if (x // 4) % 2 else (0.35, 0.35, 0.35, 1.0), non_color=True)

    mat, nt, sh = new_material("ImageHSV")
    tex = nt.nodes.new("ShaderNodeTexImage")
    tex.image = stripes
    tex.interpolation = "Closest"
    hsv = nt.nodes.new("ShaderNodeHueSaturation")
    hsv.inputs["Hue"].default_value = 0.7
    hsv.inputs["Saturation"].default_value = 0.8
    nt.links.new(tex.outputs["Color"], hsv.inputs["Color"])
    nt.links.new(hsv.outputs["Color"], sh.inputs["Color"])
    out.append(("ImageHSV", mat))

    mat, nt, sh = new_material("RampGradient", "ShaderNodeBsdfPrincipled")
    grad = nt.nodes.new("ShaderNodeTexGradient")
    ramp = nt.nodes.new("ShaderNodeValToRGB")
    ramp.color_ramp.interpolation = "B_SPLINE"
    ramp.color_ramp.elements[0].color = (0.05, 0.1, 0.6, 1.0)
    ramp.color_ramp.elements[1].color = (0.9, 0.8, 0.1, 1.0)
    e = ramp.color_ramp.elements.new(0.5)
    e.color = (0.8, 0.1, 0.1, 1.0)
    nt.links.new(grad.outputs["Fac"], ramp.inputs["Fac"])
    nt.links.new(ramp.outputs["Color"], sh.inputs["Base Color"])
    out.append(("RampGradient", mat))

    mat, nt, sh = new_material("ColorAttr")
    ca = nt.nodes.new("ShaderNodeVertexColor")
    ca.layer_name = "Paint"
    nt.links.new(ca.outputs["Color"], sh.inputs["Color"])
    out.append(("ColorAttr", mat))

    mat, nt, sh = new_material("RoughImage", "ShaderNodeBsdfGlossy")
    sh.inputs["Color"].default_value = (0.9, 0.9, 0.9, 1.0)
    tex = nt.nodes.new("ShaderNodeTexImage")
    tex.image = rough
    tex.interpolation = "Closest"
    nt.links.new(tex.outputs["Color"], sh.inputs["Roughness"])
    out.append(("RoughImage", mat))

    mat, nt, sh = new_material("MetalImage", "ShaderNodeBsdfPrincipled")
    sh.inputs["Base Color"].default_value = (0.9, 0.4, 0.1, 1.0)
    sh.inputs["Roughness"].default_value = 0.3
    tex = nt.nodes.new("ShaderNodeTexImage")
    tex.image = rough
    tex.interpolation = "Closest"
    nt.links.new(tex.outputs["Color"], sh.inputs["Metallic"])
    out.append(("MetalImage", mat))

    mat, nt, sh = new_material("UVMath")
    uvn = nt.nodes.new("ShaderNodeUVMap")
    uvn.uv_map = "Rotated"
    sep = nt.nodes.new("ShaderNodeSeparateXYZ")
    mul = nt.nodes.new("ShaderNodeMath")
    mul.operation = "PINGPONG"
    mul.inputs[1].default_value = 0.3
    mix = nt.nodes.new("ShaderNodeMix")
    mix.data_type = "RGBA"
    mix.blend_type = "OVERLAY"
    ident(mix.inputs, "A_Color").default_value = (0.2, 0.6, 0.3, 1.0)
    ident(mix.inputs, "B_Color").default_value = (0.9, 0.2, 0.6, 1.0)
    nt.links.new(uvn.outputs["UV"], sep.inputs["Vector"])
    nt.links.new(sep.outputs["X"], mul.inputs[0])
    nt.links.new(mul.outputs["Value"], ident(mix.inputs, "Factor_Float"))
    nt.links.new(ident(mix.outputs, "Result_Color"), sh.inputs["Color"])
    out.append(("UVMath", mat))

    mat, nt, sh = new_material("CheckerMapping")
    mapping = nt.nodes.new("ShaderNodeMapping")
    mapping.inputs["Rotation"].default_value = (0.0, 0.0, 0.4)
    mapping.inputs["Scale"].default_value = (1.5, 1.0, 1.0)
    tc = nt.nodes.new("ShaderNodeTexCoord")
    chk = nt.nodes.new("ShaderNodeTexChecker")
    chk.inputs["Scale"].default_value = 3.0
    chk.inputs["Color1"].default_value = (0.8, 0.7, 0.2, 1.0)
    chk.inputs["Color2"].default_value = (0.1, 0.2, 0.5, 1.0)
    nt.links.new(tc.outputs["Object"], mapping.inputs["Vector"])
    nt.links.new(mapping.outputs["Vector"], chk.inputs["Vector"])
    nt.links.new(chk.outputs["Color"], sh.inputs["Color"])
    out.append(("CheckerMapping", mat))

    mat, nt, sh = new_material("MapRangeChain")
    tc = nt.nodes.new("ShaderNodeTexCoord")
    sep = nt.nodes.new("ShaderNodeSeparateXYZ")
    mr = nt.nodes.new("ShaderNodeMapRange")
    mr.interpolation_type = "SMOOTHSTEP"
    mr.inputs[1].default_value = 0.2
    mr.inputs[2].default_value = 0.8
    comb = nt.nodes.new("ShaderNodeCombineColor")
    comb.mode = "HSV"
    comb.inputs[1].default_value = 0.7
    comb.inputs[2].default_value = 0.8
    nt.links.new(tc.outputs["Generated"], sep.inputs["Vector"])
    nt.links.new(sep.outputs["Y"], mr.inputs[0])
    nt.links.new(mr.outputs["Result"], comb.inputs[0])
    nt.links.new(comb.outputs["Color"], sh.inputs["Color"])
    out.append(("MapRangeChain", mat))

    mat, nt, sh = new_material("InvertGamma")
    tex = nt.nodes.new("ShaderNodeTexImage")
    tex.image = stripes
    tex.interpolation = "Closest"
    inv = nt.nodes.new("ShaderNodeInvert")
    inv.inputs["Fac"].default_value = 0.8
    gam = nt.nodes.new("ShaderNodeGamma")
    gam.inputs["Gamma"].default_value = 1.8
    bc = nt.nodes.new("ShaderNodeBrightContrast")
    bc.inputs["Contrast"].default_value = 0.3
    nt.links.new(tex.outputs["Color"], inv.inputs["Color"])
    nt.links.new(inv.outputs["Color"], gam.inputs["Color"])
    nt.links.new(gam.outputs["Color"], bc.inputs["Color"])
    nt.links.new(bc.outputs["Color"], sh.inputs["Color"])
    out.append(("InvertGamma", mat))

    # A node group with a Math node inside, reached through a reroute.
    group = bpy.data.node_groups.new("Darken", "ShaderNodeTree")
    if hasattr(group, "interface"):
        group.interface.new_socket("Color", in_out="INPUT", socket_type="NodeSocketColor")
        group.interface.new_socket("Color", in_out="OUTPUT", socket_type="NodeSocketColor")
    else:
        group.inputs.new("NodeSocketColor", "Color")
        group.outputs.new("NodeSocketColor", "Color")
    gin = group.nodes.new("NodeGroupInput")
    gout = group.nodes.new("NodeGroupOutput")
    mixg = group.nodes.new("ShaderNodeMix")
    mixg.data_type = "RGBA"
    mixg.blend_type = "MULTIPLY"
    ident(mixg.inputs, "Factor_Float").default_value = 1.0
    ident(mixg.inputs, "B_Color").default_value = (0.5, 0.9, 0.9, 1.0)
    group.links.new(gin.outputs[0], ident(mixg.inputs, "A_Color"))
    group.links.new(ident(mixg.outputs, "Result_Color"), gout.inputs[0])
    mat, nt, sh = new_material("GroupReroute")
    tex = nt.nodes.new("ShaderNodeTexImage")
    tex.image = stripes
    tex.interpolation = "Closest"
    gnode = nt.nodes.new("ShaderNodeGroup")
    gnode.node_tree = group
    rr = nt.nodes.new("NodeReroute")
    nt.links.new(tex.outputs["Color"], gnode.inputs[0])
    nt.links.new(gnode.outputs[0], rr.inputs[0])
    nt.links.new(rr.outputs[0], sh.inputs["Color"])
    out.append(("GroupReroute", mat))

    mat, nt, sh = new_material("EmissionRamp", "ShaderNodeEmission")
    tc = nt.nodes.new("ShaderNodeTexCoord")
    sep = nt.nodes.new("ShaderNodeSeparateXYZ")
    ramp = nt.nodes.new("ShaderNodeValToRGB")
    ramp.color_ramp.interpolation = "CONSTANT"
    ramp.color_ramp.elements[0].color = (0.9, 0.3, 0.1, 1.0)
    ramp.color_ramp.elements[1].position = 0.5
    ramp.color_ramp.elements[1].color = (0.1, 0.5, 0.9, 1.0)
    nt.links.new(tc.outputs["UV"], sep.inputs["Vector"])
    nt.links.new(sep.outputs["X"], ramp.inputs["Fac"])
    nt.links.new(ramp.outputs["Color"], sh.inputs["Color"])
    sh.inputs["Strength"].default_value = 0.8
    out.append(("EmissionRamp", mat))

    mat, nt, sh = new_material("MutedLink")
    tex = nt.nodes.new("ShaderNodeTexImage")
    tex.image = stripes
    inv = nt.nodes.new("ShaderNodeInvert")
    inv.mute = True  # a muted node passes its Color through
    nt.links.new(tex.outputs["Color"], inv.inputs["Color"])
    nt.links.new(inv.outputs["Color"], sh.inputs["Color"])
    out.append(("MutedNode", mat))

    def mixed(name, fac_builder=None, add=False):
        mat = bpy.data.materials.new(name)
        mat.use_nodes = True
        nt = mat.node_tree
        nt.nodes.clear()
        outn = nt.nodes.new("ShaderNodeOutputMaterial")
        a = nt.nodes.new("ShaderNodeBsdfDiffuse")
        a.inputs["Color"].default_value = (0.8, 0.15, 0.1, 1.0)
        if add:
            b = nt.nodes.new("ShaderNodeEmission")
            b.inputs["Color"].default_value = (0.1, 0.3, 0.9, 1.0)
            b.inputs["Strength"].default_value = 0.5
            mix = nt.nodes.new("ShaderNodeAddShader")
            nt.links.new(a.outputs[0], mix.inputs[0])
            nt.links.new(b.outputs[0], mix.inputs[1])
        else:
            b = nt.nodes.new("ShaderNodeBsdfGlossy")
            b.inputs["Color"].default_value = (0.9, 0.9, 0.9, 1.0)
            b.inputs["Roughness"].default_value = 0.35
            mix = nt.nodes.new("ShaderNodeMixShader")
            mix.inputs["Fac"].default_value = 0.4
            if fac_builder is not None:
                nt.links.new(fac_builder(nt), mix.inputs["Fac"])
            nt.links.new(a.outputs[0], mix.inputs[1])
            nt.links.new(b.outputs[0], mix.inputs[2])
        nt.links.new(mix.outputs[0], outn.inputs["Surface"])
        out.append((name, mat))

    def checker_fac(nt):
        chk = nt.nodes.new("ShaderNodeTexChecker")
        chk.inputs["Scale"].default_value = 3.0
        return chk.outputs["Fac"]

    mat, nt, sh = new_material("AlphaChecker", "ShaderNodeBsdfPrincipled")
    sh.inputs["Base Color"].default_value = (0.9, 0.2, 0.1, 1.0)
    chk = nt.nodes.new("ShaderNodeTexChecker")
    chk.inputs["Scale"].default_value = 2.0
    nt.links.new(chk.outputs["Fac"], sh.inputs["Alpha"])
    out.append(("AlphaChecker", mat))

    mat, nt, sh = new_material("AlphaConst", "ShaderNodeBsdfPrincipled")
    sh.inputs["Base Color"].default_value = (0.1, 0.7, 0.2, 1.0)
    sh.inputs["Alpha"].default_value = 0.4
    out.append(("AlphaConst", mat))

    mat, nt, tr, df, _ = mix_material("MixTransparent", "ShaderNodeBsdfTransparent", "ShaderNodeBsdfDiffuse", 0.6)
    # Tinted: what passes (the floor behind the tile, and the tile's shadow on it) is
    # multiplied by the colour.
    tr.inputs["Color"].default_value = (0.95, 0.55, 0.2, 1.0)
    df.inputs["Color"].default_value = (0.2, 0.3, 0.9, 1.0)
    out.append(("MixTransparent", mat))

    mat, nt, sh = new_material("Translucent", "ShaderNodeBsdfTranslucent")
    sh.inputs["Color"].default_value = (0.9, 0.6, 0.3, 1.0)
    out.append(("Translucent", mat))

    mat, nt, sh = new_material("BumpNoise", "ShaderNodeBsdfPrincipled")
    sh.inputs["Base Color"].default_value = (0.7, 0.7, 0.7, 1.0)
    sh.inputs["Roughness"].default_value = 0.4
    nz = nt.nodes.new("ShaderNodeTexNoise")
    nz.inputs["Scale"].default_value = 3.0
    bump = nt.nodes.new("ShaderNodeBump")
    bump.inputs["Strength"].default_value = 0.8
    bump.inputs["Distance"].default_value = 0.3
    nt.links.new(nz.outputs["Fac"], bump.inputs["Height"])
    nt.links.new(bump.outputs["Normal"], sh.inputs["Normal"])
    out.append(("BumpNoise", mat))

    mat, nt, sh = new_material("RGBCurves")
    tex = nt.nodes.new("ShaderNodeTexImage")
    tex.image = stripes
    tex.interpolation = "Closest"
    cu = nt.nodes.new("ShaderNodeRGBCurve")
    pts = cu.mapping.curves[3].points
    pts.new(0.3, 0.7)
    red = cu.mapping.curves[0].points
    red[1].location = (1.0, 0.6)
    cu.mapping.update()
    nt.links.new(tex.outputs["Color"], cu.inputs["Color"])
    nt.links.new(cu.outputs["Color"], sh.inputs["Color"])
    out.append(("RGBCurves", mat))

    # A tangent-space normal map through a Mapping node (the graph path, not glTF's normalTexture).
    nmap = image("Tilts", 8, 8, lambda x, y: (0.8, 0.5, 0.8, 1.0) if (x // 2) % 2 else (0.3, 0.65, 0.85, 1.0),
                 non_color=True)
    mat, nt, sh = new_material("NormalMapGraph", "ShaderNodeBsdfPrincipled")
    sh.inputs["Base Color"].default_value = (0.6, 0.6, 0.6, 1.0)
    uvn = nt.nodes.new("ShaderNodeUVMap")
    mapping = nt.nodes.new("ShaderNodeMapping")
    mapping.inputs["Scale"].default_value = (1.5, 1.5, 1.0)
    tex = nt.nodes.new("ShaderNodeTexImage")
    tex.image = nmap
    tex.interpolation = "Closest"
    nm = nt.nodes.new("ShaderNodeNormalMap")
    nm.inputs["Strength"].default_value = 0.9
    nt.links.new(uvn.outputs["UV"], mapping.inputs["Vector"])
    nt.links.new(mapping.outputs["Vector"], tex.inputs["Vector"])
    nt.links.new(tex.outputs["Color"], nm.inputs["Color"])
    nt.links.new(nm.outputs["Normal"], sh.inputs["Normal"])
    out.append(("NormalMapGraph", mat))


    # World-space vectors in Blender's frame (Z up): an up-facing tile's normal z is 1, and its
    # world position x varies across the grid.
    mat, nt, sh = new_material("GeometryWorld", "ShaderNodeEmission")
    geo = nt.nodes.new("ShaderNodeNewGeometry")
    sepn = nt.nodes.new("ShaderNodeSeparateXYZ")
    sepp = nt.nodes.new("ShaderNodeSeparateXYZ")
    comb = nt.nodes.new("ShaderNodeCombineXYZ")
    nt.links.new(geo.outputs["Normal"], sepn.inputs[0])
    nt.links.new(geo.outputs["Position"], sepp.inputs[0])
    nt.links.new(sepn.outputs["Z"], comb.inputs[0])
    nt.links.new(sepn.outputs["Y"], comb.inputs[1])
    frac = nt.nodes.new("ShaderNodeMath")
    frac.operation = "FRACT"
    nt.links.new(sepp.outputs["Y"], frac.inputs[0])
    nt.links.new(frac.outputs[0], comb.inputs[2])
    nt.links.new(comb.outputs[0], sh.inputs["Color"])
    out.append(("GeometryWorld", mat))

    # Wavelength: 400-700 nm across the tile (Generated X through Map Range): a rainbow.
    mat, nt, sh = new_material("WavelengthRainbow", "ShaderNodeEmission")
    tc = nt.nodes.new("ShaderNodeTexCoord")
    sep = nt.nodes.new("ShaderNodeSeparateXYZ")
    mr = nt.nodes.new("ShaderNodeMapRange")
    mr.inputs[3].default_value = 400.0
    mr.inputs[4].default_value = 700.0
    wl = nt.nodes.new("ShaderNodeWavelength")
    nt.links.new(tc.outputs["Generated"], sep.inputs[0])
    nt.links.new(sep.outputs["X"], mr.inputs[0])
    nt.links.new(mr.outputs[0], wl.inputs[0])
    nt.links.new(wl.outputs[0], sh.inputs["Color"])
    out.append(("WavelengthRainbow", mat))

    # Vector Curves reshaping the generated coordinates (X scaled down, Y bent up).
    mat, nt, sh = new_material("VectorCurves", "ShaderNodeEmission")
    tc = nt.nodes.new("ShaderNodeTexCoord")
    vc = nt.nodes.new("ShaderNodeVectorCurve")
    xs = vc.mapping.curves[0].points
    xs[0].location = (-1.0, 0.1)  # positive outputs: emission colours below 0 differ by renderer
    xs[len(xs) - 1].location = (1.0, 0.4)
    vc.mapping.curves[1].points.new(0.5, 0.9)
    vc.mapping.update()
    nt.links.new(tc.outputs["Generated"], vc.inputs["Vector"])
    nt.links.new(vc.outputs["Vector"], sh.inputs["Color"])
    out.append(("VectorCurves", mat))

    mixed("MixDiffuseGlossy")
    mixed("MixCheckerFac", checker_fac)
    mixed("AddEmission", add=True)

    # An object-space normal map on a tile turned about Z and tilted (build_scene): the
    # object's normal matrix takes the encoded normals to world space.
    omap = image("ObjectTilts", 8, 8, lambda x, y: (0.75, 0.5, 0.85, 1.0) if (x // 2) % 2 else (0.4, 0.7, 0.85, 1.0),
                 non_color=True)
    mat, nt, sh = new_material("NormalMapObject", "ShaderNodeBsdfPrincipled")
    sh.inputs["Base Color"].default_value = (0.6, 0.6, 0.6, 1.0)
    tex = nt.nodes.new("ShaderNodeTexImage")
    tex.image = omap
    tex.interpolation = "Closest"
    nm = nt.nodes.new("ShaderNodeNormalMap")
    nm.space = "OBJECT"
    nt.links.new(tex.outputs["Color"], nm.inputs["Color"])
    nt.links.new(nm.outputs["Normal"], sh.inputs["Normal"])
    out.append(("NormalMapObject", mat))
    return out


def build_scene():
    C.reset()
    sc = bpy.context.scene
    tiles = setups()
    rows = (len(tiles) + COLS - 1) // COLS
    for i, (name, mat) in enumerate(tiles):
        r, c = divmod(i, COLS)
        # The object-space normal map's tile is turned, so object and world space differ.
        rotation = (0.25, 0.0, 0.3) if name == "NormalMapObject" else (0.0, 0.0, 0.0)
        C.mesh_object(name, tile_mesh, mat, location=(c * 1.2 - (COLS - 1) * 0.6, (rows - 1) * 0.6 - r * 1.2, 0.0),
                      rotation=rotation)
    floor = C.material("Floor", "ShaderNodeBsdfDiffuse", (0.5, 0.45, 0.4))
    C.mesh_object("Floor", C.plane(40.0), floor, location=(0.0, 0.0, -0.5))
    C.world((1.0, 1.0, 1.0), 0.3)
    C.light("Sun", "SUN", 4.0, (0, 0, 5), rotation=(1.0, 0.0, 0.5), angle=0.0)
    cam = C.camera((0.0, 0.0, 5.0), (0.0, 0.0, 0.0))
    cam.data.type = "ORTHO"
    cam.data.ortho_scale = COLS * 1.2
    sc.render.resolution_x = int(COLS * 1.2 / 1.0 * TILE_PX / 1.0)
    sc.render.resolution_y = int(rows * 1.2 * TILE_PX)
    sc.render.resolution_percentage = 100
    return sc, tiles, rows


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
        ratio = ma / np.maximum(mb, 1e-4)
        rel = C.rel_mse(C.blur(a), C.blur(b))
        # Within 10% per channel (absolutely for channels near 0).
        ok = bool(np.all(np.abs(ma - mb) <= 0.10 * np.maximum(mb, 0.02))) and rel <= 0.03
        if name in {"BumpNoise", "NormalMapGraph", "NormalMapObject"}:
            # The bump pattern itself (a flat tile would match the means too).
            la, lb = a.mean(axis=-1).ravel(), b.mean(axis=-1).ravel()
            corr = float(np.corrcoef(la, lb)[0, 1])
            print("  " + name + ": pattern std %.4f (Cycles %.4f), correlation %.3f" % (la.std(), lb.std(), corr))
            # Blender 3.4's Cycles bumps a Noise height differently (the pattern correlates 0.88
            # with Prism's, which follows 4.x+: 0.99 there); its means still agree.
            min_corr = 0.85 if bpy.app.version < (4, 0, 0) else 0.9
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
        tc = nt.nodes.new("ShaderNodeTexCoord")
        sep = nt.nodes.new("ShaderNodeSeparateXYZ")
        mr = nt.nodes.new("ShaderNodeMapRange")
        mr.inputs[3].default_value = 1000.0
        mr.inputs[4].default_value = 10000.0
        bb = nt.nodes.new("ShaderNodeBlackbody")
        nt.links.new(tc.outputs["Generated"], sep.inputs[0])
        nt.links.new(sep.outputs["X"], mr.inputs[0])
        nt.links.new(mr.outputs[0], bb.inputs[0])
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


def test_noise_textures_match_cycles():
    """Noise (fBM, ridged, hetero terrain; 1D-4D, distortion, colour) and White Noise on emission
    tiles: per-pixel error against Cycles within 1% of the range (the 99.5th percentile, tile
    interiors; pixel averages over the same footprint)."""
    spp = 256
    results = []
    for engine in ("cycles", "prism"):
        C.reset()
        sc = bpy.context.scene
        tiles = noise_tiles()
        for i, (name, mat) in enumerate(tiles):
            C.mesh_object(name, tile_mesh, mat, location=(i * 1.2 - (len(tiles) - 1) * 0.6, 0.0, 0.0))
        C.world((0.0, 0.0, 0.0), 0.0)
        cam = C.camera((0.0, 0.0, 5.0), (0.0, 0.0, 0.0))
        cam.data.type = "ORTHO"
        cam.data.ortho_scale = len(tiles) * 1.2
        sc.render.resolution_x = len(tiles) * 40
        sc.render.resolution_percentage = 100
        sc.render.resolution_y = 40
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


def test_unsupported_nodes_are_named():
    """A node Prism cannot evaluate yet is one warning naming material, node and type, shown in
    the status bar (RenderEngine.report); the input falls back to its own value."""
    C.reset()
    sc = bpy.context.scene
    mat, nt, sh = new_material("Wavy")
    wave = nt.nodes.new("ShaderNodeTexGabor" if hasattr(bpy.types, "ShaderNodeTexGabor") else "ShaderNodeBlackbody")
    wave.name = "MyWaves"
    nt.links.new(wave.outputs[0], sh.inputs["Color"])
    sh.inputs["Color"].default_value = (0.2, 0.7, 0.2, 1.0)
    C.mesh_object("Tile", tile_mesh, mat)
    C.world((1.0, 1.0, 1.0), 1.0)
    cam = C.camera((0.0, 0.0, 5.0), (0.0, 0.0, 0.0))
    cam.data.type = "ORTHO"
    cam.data.ortho_scale = 0.8
    sc.render.resolution_x = sc.render.resolution_y = 16
    C.use_prism(sc, spp=4)
    px = C.render_pixels(sc, os.path.join(OUT, "wavy.exr"))[..., :3]
    warnings = prism.engine.LAST["warnings"]
    named = [w for w in warnings if "Wavy" in w and "MyWaves" in w and wave.bl_idname in w]
    C.check(len(named) == 1, "one warning names material, node and type: %s" % warnings)
    m = px.mean(axis=(0, 1))
    C.check(m[1] > 2.0 * m[0], "the Color input's own value (green) is used: %s" % m)


if __name__ == "__main__":
    # Test names: after "--" under `blender -b ... --python`, else the script's arguments.
    argv = sys.argv
    names = argv[argv.index("--") + 1:] if "--" in argv else ([] if "--python" in argv else argv[1:])
    names = names or [n for n in sorted(globals()) if n.startswith("test_")]
    for n in names:
        print(n, flush=True)
        globals()[n]()
    print("all node graph tests passed")

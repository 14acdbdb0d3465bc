"""The node setups of the shading-graph test (issue 12): one flat tile per everyday Blender
node setup, in a grid seen from above by an orthographic camera under a white world and a
side sun. Used by tests/addon/test_node_graphs.py (against Cycles) and scenes/build_scenes.py
(the committed `scenes/node_setups` export).
"""

import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import bpy  # noqa: E402
import bmesh  # noqa: E402
import numpy as np  # noqa: E402

import common as C  # noqa: E402

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
    group, gin, gout = C.node_group("Darken", [("Color", "NodeSocketColor")], [("Color", "NodeSocketColor")])
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
    bump = C.noise_bump(nt)
    nt.links.new(bump.outputs["Normal"], sh.inputs["Normal"])
    out.append(("BumpNoise", mat))

    # Blender 4.5+'s Filter Width: 3 pixels turn a checker's steps into bevelled bands of
    # about that width (0.1 would leave pixel-thin edges).
    mat, nt, sh = new_material("BumpWide", "ShaderNodeBsdfPrincipled")
    bump = nt.nodes.new("ShaderNodeBump")
    if "Filter Width" in bump.inputs:
        sh.inputs["Base Color"].default_value = (0.7, 0.7, 0.7, 1.0)
        sh.inputs["Roughness"].default_value = 0.4
        chk = nt.nodes.new("ShaderNodeTexChecker")
        chk.inputs["Scale"].default_value = 4.0
        bump.inputs["Filter Width"].default_value = 3.0
        bump.inputs["Distance"].default_value = 0.02
        nt.links.new(chk.outputs["Fac"], bump.inputs["Height"])
        nt.links.new(bump.outputs["Normal"], sh.inputs["Normal"])
        out.append(("BumpWide", mat))

    # One Bump feeding both shaders of a Mix: the material's normal (graph `inputs.normal`
    # beside the closures).
    mat, nt, df, gl, mx = mix_material("MixBump", "ShaderNodeBsdfDiffuse", "ShaderNodeBsdfGlossy", 0.4)
    df.inputs["Color"].default_value = (0.7, 0.5, 0.3, 1.0)
    gl.inputs["Roughness"].default_value = 0.3
    bump = C.noise_bump(nt, strength=0.3)
    nt.links.new(bump.outputs["Normal"], df.inputs["Normal"])
    nt.links.new(bump.outputs["Normal"], gl.inputs["Normal"])
    out.append(("MixBump", mat))

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
    wl = nt.nodes.new("ShaderNodeWavelength")
    nt.links.new(C.generated_x_range(nt, 400.0, 700.0), wl.inputs[0])
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

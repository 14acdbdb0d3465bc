"""Run by Blender (3.4 or 5.0): export Principled materials through the add-on, print the JSON.

    blender -b --factory-startup -P export_principled.py -- OUT_DIR
Prints one line "EXPORT <json>" with the glTF materials and the material JSON.
"""
import json
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import bpy  # noqa: E402
import common as C  # noqa: E402

out = sys.argv[sys.argv.index("--") + 1]
C.enable_addon()
sc = C.simple_scene()
v4 = bpy.app.version >= (4, 0, 0)


def principled(name, **inputs):
    mat = C.material(name, "ShaderNodeBsdfPrincipled", (0.5, 0.25, 0.125))
    node = next(n for n in mat.node_tree.nodes if n.type == "BSDF_PRINCIPLED")
    for k, v in inputs.items():
        node.inputs[k].default_value = v
    return mat


mats = [
    principled("Metal", Metallic=1.0, Roughness=0.25),
    principled("Glassy", **{("Transmission Weight" if v4 else "Transmission"): 1.0, "IOR": 1.33}),
    principled("Glow", **({"Emission Color": (1, 0.5, 0.25, 1), "Emission Strength": 4.0} if v4 else
                          {"Emission": (1, 0.5, 0.25, 1), "Emission Strength": 4.0})),
    principled("Spec", **{("Specular IOR Level" if v4 else "Specular"): 0.25}),
    principled("Skin", **({"Subsurface Weight": 1.0, "Subsurface Radius": (1.0, 0.5, 0.25), "Subsurface Scale": 0.1, "IOR": 1.4}
                          if v4 else {"Subsurface": 0.1, "Subsurface Radius": (1.0, 0.5, 0.25),
                                      "Subsurface Color": (0.5, 0.25, 0.125, 1), "Subsurface IOR": 1.4})),
]
# a base colour image texture (generated, not on disk)
img = bpy.data.images.new("Checker", 4, 4)
img.pixels = [1.0, 0.0, 0.0, 1.0] * 16
tex_mat = principled("Textured")
tree = tex_mat.node_tree
tex = tree.nodes.new("ShaderNodeTexImage")
tex.image = img
tree.links.new(tex.outputs["Color"], next(n for n in tree.nodes if n.type == "BSDF_PRINCIPLED").inputs["Base Color"])
mats.append(tex_mat)
# a node graph: Generated x -> Math -> Color Ramp -> Base Color; Color Attribute -> Mix -> Roughness
graph_mat = principled("Graphed")
tree = graph_mat.node_tree
bsdf = next(n for n in tree.nodes if n.type == "BSDF_PRINCIPLED")
tc = tree.nodes.new("ShaderNodeTexCoord")
sep = tree.nodes.new("ShaderNodeSeparateXYZ")
mul = tree.nodes.new("ShaderNodeMath")
mul.operation = "MULTIPLY"
mul.inputs[1].default_value = 2.0
ramp = tree.nodes.new("ShaderNodeValToRGB")
ramp.color_ramp.interpolation = "EASE"
tree.links.new(tc.outputs["Generated"], sep.inputs["Vector"])
tree.links.new(sep.outputs["X"], mul.inputs[0])
tree.links.new(mul.outputs["Value"], ramp.inputs["Fac"])
tree.links.new(ramp.outputs["Color"], bsdf.inputs["Base Color"])
attr = tree.nodes.new("ShaderNodeVertexColor")
mix = tree.nodes.new("ShaderNodeMix")
mix.data_type = "FLOAT"
tree.links.new(attr.outputs["Alpha"], next(x for x in mix.inputs if x.identifier == "B_Float"))
tree.links.new(next(x for x in mix.outputs if x.identifier == "Result_Float"), bsdf.inputs["Roughness"])
mats.append(graph_mat)
for i, m in enumerate(mats):
    C.mesh_object("Obj%d" % i, C.cube(0.3), m, location=(i - 3.0, 2.0, 0.3))
from prism import export  # noqa: E402

os.makedirs(out, exist_ok=True)
gltf, mj, warnings, tris = export.export_scene(bpy.context.evaluated_depsgraph_get(), out)
g = json.load(open(gltf))
print("EXPORT " + json.dumps({"materials": g["materials"], "images": g.get("images", []),
                              "json": json.load(open(mj)), "warnings": warnings,
                              "files": sorted(os.listdir(out))}))

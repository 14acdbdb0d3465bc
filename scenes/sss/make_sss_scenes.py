#!/usr/bin/env python3
"""Write the subsurface-scattering scenes (glTF 2.0 + Prism sidecar), reusing the Cornell box
builder of scenes/make_cornell.py. Stdlib only, deterministic output.

Outputs (under scenes/sss/):
  cornell_sss.gltf / .materials.json      Cornell box; tall box Marble, left sphere Skin1,
                                          right sphere Potato (Jensen et al. 2001 presets,
                                          table method), used by the SSS benchmark
  cornell_walk.gltf / .materials.json     the same with "method": "random_walk"
  cornell_diffuse.gltf / .materials.json  the same geometry, every object diffuse (bench baseline)
  skin_pair.gltf / .materials.json        two spheres: left diffuse with Skin1's RGB effective
                                          albedo, right SSS Skin1 (the report's Figure 2)
  media_trio.gltf / .materials.json       Chicken1, Marble, Potato spheres side by side
                                          (the report's Figure 3)

Units: 1 unit = 1 m. The presets are in mm^-1; "scale": 100 makes the 0.3 m objects scatter
like 3 cm ones (with the physical 1000 the mean free paths of a few tenths of a mm look almost
diffuse at this size).
"""

import base64
import json
import os
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.dirname(HERE))
import make_cornell as mc  # noqa: E402

SCALE = 100.0
ETA = 1.33


def sss(preset, method="table", roughness=0.0):
    return {
        "subsurface": {
            "preset": preset,
            "scale": SCALE,
            "eta": ETA,
            "roughness": roughness,
            "method": method,
        }
    }


def gltf_document(b, materials, meshes, nodes, roots, camera_node_translation, yfov=0.6911):
    nodes = nodes + [{"name": "Camera", "camera": 0, "translation": camera_node_translation}]
    return {
        "asset": {"version": "2.0", "generator": "Prism scenes/sss/make_sss_scenes.py"},
        "extensionsUsed": ["KHR_materials_emissive_strength", "KHR_materials_specular"],
        "scene": 0,
        "scenes": [{"name": "SSS", "nodes": roots + [len(nodes) - 1]}],
        "nodes": nodes,
        "cameras": [
            {
                "name": "Camera",
                "type": "perspective",
                "perspective": {"yfov": yfov, "aspectRatio": 1.0, "znear": 0.01, "zfar": 100.0},
            }
        ],
        "meshes": meshes,
        "materials": materials,
        "accessors": b.accessors,
        "bufferViews": b.buffer_views,
        "buffers": [
            {
                "byteLength": len(b.blob),
                "uri": "data:application/octet-stream;base64,"
                + base64.b64encode(bytes(b.blob)).decode("ascii"),
            }
        ],
    }


def light_material(strength):
    return {
        "name": "Light",
        "pbrMetallicRoughness": {"baseColorFactor": [0, 0, 0, 1], "metallicFactor": 0.0, "roughnessFactor": 1.0},
        "emissiveFactor": [1.0, 1.0, 1.0],
        "extensions": {
            "KHR_materials_emissive_strength": {"emissiveStrength": strength},
            "KHR_materials_specular": {"specularFactor": 0.0},
        },
    }


def cornell():
    """Cornell box with three objects of their own materials (Marble box, Skin and Potato spheres)."""
    b = mc.Builder()
    materials = [
        mc.diffuse("White", (0.73, 0.73, 0.73)),
        mc.diffuse("Red", (0.63, 0.065, 0.05)),
        mc.diffuse("Green", (0.14, 0.45, 0.091)),
        light_material(15.0),
        mc.diffuse("Marble", (0.83, 0.79, 0.75)),
        mc.diffuse("Skin", (0.45, 0.22, 0.12)),
        mc.diffuse("Potato", (0.77, 0.62, 0.21)),
    ]
    WHITE, RED, GREEN, LIGHT, MARBLE, SKIN, POTATO = range(7)

    def prim(geo, material):
        attrs, ind = b.geometry(geo.tup() if isinstance(geo, mc.Geo) else geo)
        return {"attributes": attrs, "indices": ind, "material": material, "mode": 4}

    white = mc.Geo()
    white.quad((-1, 0, 1), (2, 0, 0), (0, 0, -2))
    white.quad((-1, 2, -1), (2, 0, 0), (0, 0, 2))
    white.quad((-1, 0, -1), (2, 0, 0), (0, 2, 0))
    red = mc.Geo().quad((-1, 0, 1), (0, 0, -2), (0, 2, 0))
    green = mc.Geo().quad((1, 0, -1), (0, 0, 2), (0, 2, 0))
    light = mc.Geo().quad((-0.25, 1.98, -0.2), (0.5, 0, 0), (0, 0, 0.4))
    sphere = mc.uv_sphere_geo(0.3)
    meshes = [
        {"name": "Room", "primitives": [prim(white, WHITE), prim(red, RED), prim(green, GREEN)]},
        {"name": "Light", "primitives": [prim(light, LIGHT)]},
        {"name": "TallBox", "primitives": [prim(mc.box_geo(0.3, 0.6, 0.3), MARBLE)]},
        {"name": "SkinSphere", "primitives": [prim(sphere, SKIN)]},
        {"name": "PotatoSphere", "primitives": [prim(sphere, POTATO)]},
    ]
    nodes = [
        {"name": "Room", "mesh": 0},
        {"name": "Light", "mesh": 1},
        {"name": "TallBox", "mesh": 2, "translation": [-0.4, 0.6, -0.4], "rotation": mc.rot_y(15.0)},
        {"name": "SkinSphere", "mesh": 3, "translation": [0.5, 0.3, -0.3]},
        {"name": "PotatoSphere", "mesh": 4, "translation": [-0.2, 0.3, 0.45]},
    ]
    return gltf_document(b, materials, meshes, nodes, [0, 1, 2, 3, 4], [0.0, 1.0, 3.9])


def spheres_on_floor(names_colors):
    """Spheres of radius 0.3 in a row on a white floor, lit by a large area light above-front."""
    b = mc.Builder()
    materials = [mc.diffuse("Floor", (0.6, 0.6, 0.6)), light_material(8.0)]
    FLOOR, LIGHT = 0, 1

    def prim(geo, material):
        attrs, ind = b.geometry(geo.tup() if isinstance(geo, mc.Geo) else geo)
        return {"attributes": attrs, "indices": ind, "material": material, "mode": 4}

    floor = mc.Geo().quad((-4, 0, 4), (8, 0, 0), (0, 0, -8))
    # 1.6 x 0.8 quad at y = 2.2 above and in front of the spheres, facing down.
    light = mc.Geo().quad((-0.8, 2.2, 0.2), (1.6, 0, 0), (0, 0, 0.8))
    sphere = mc.uv_sphere_geo(0.3, 64, 32)
    meshes = [
        {"name": "Floor", "primitives": [prim(floor, FLOOR)]},
        {"name": "Light", "primitives": [prim(light, LIGHT)]},
    ]
    nodes = [{"name": "Floor", "mesh": 0}, {"name": "Light", "mesh": 1}]
    n = len(names_colors)
    for i, (name, rgb) in enumerate(names_colors):
        materials.append(mc.diffuse(name, rgb))
        meshes.append({"name": name + "Sphere", "primitives": [prim(sphere, len(materials) - 1)]})
        x = (i - (n - 1) / 2.0) * 0.75
        nodes.append({"name": name + "Sphere", "mesh": len(meshes) - 1, "translation": [x, 0.3, 0.0]})
    return gltf_document(b, materials, meshes, nodes, list(range(len(nodes))), [0.0, 0.45, 3.0], yfov=0.6)


RENDER = {"spp": 256, "width": 384, "height": 384, "max_depth": 16}
BLACK_WORLD = {"color": [0, 0, 0], "strength": 0}


def write(name, gltf, sidecar_materials, world=BLACK_WORLD, render=RENDER):
    path = os.path.join(HERE, name + ".gltf")
    with open(path, "w", newline="\n") as f:
        json.dump(gltf, f, indent=1)
        f.write("\n")
    side = {"version": 1, "materials": sidecar_materials, "world": world, "render": render}
    with open(os.path.join(HERE, name + ".materials.json"), "w", newline="\n") as f:
        json.dump(side, f, indent=1)
        f.write("\n")
    print("wrote", path)


def main():
    c = cornell()
    bench_render = {"spp": 64, "width": 256, "height": 256, "max_depth": 16}
    write(
        "cornell_sss",
        c,
        {"Marble": sss("Marble"), "Skin": sss("Skin1"), "Potato": sss("Potato")},
        render=bench_render,
    )
    write(
        "cornell_walk",
        c,
        {
            "Marble": sss("Marble", "random_walk"),
            "Skin": sss("Skin1", "random_walk"),
            "Potato": sss("Potato", "random_walk"),
        },
        render=bench_render,
    )
    write("cornell_diffuse", c, {}, render=bench_render)
    # Skin1's RGB effective albedo (table, eta 1.33): (0.447, 0.217, 0.120).
    pair = spheres_on_floor([("SkinDiffuse", (0.447, 0.217, 0.120)), ("Skin", (0.447, 0.217, 0.120))])
    write("skin_pair", pair, {"Skin": sss("Skin1")}, world={"color": [0.02, 0.02, 0.02], "strength": 1.0})
    trio = spheres_on_floor(
        [("Chicken", (0.3, 0.15, 0.1)), ("Marble", (0.83, 0.79, 0.75)), ("Potato", (0.77, 0.62, 0.21))]
    )
    write(
        "media_trio",
        trio,
        {"Chicken": sss("Chicken1"), "Marble": sss("Marble"), "Potato": sss("Potato")},
        world={"color": [0.02, 0.02, 0.02], "strength": 1.0},
    )


if __name__ == "__main__":
    main()

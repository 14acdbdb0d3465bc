"""The Properties editor with Prism as the render engine shows what a Blender user expects:
the light's colour, power and size, the world's surface, the material slots and surface, the
camera's depth of field. Runs in the bpy wheel (5.0.1) and in Debian's blender 3.4:

    .venv-bpy/bin/python tests/addon/test_panels.py [TEST_NAME ...]
    blender -b --factory-startup --python-exit-code 1 --python tests/addon/test_panels.py [-- TEST_NAME ...]

Needs BLENDER_USER_SCRIPTS pointing at a folder with addons/prism (run_addon_tests.sh does it).

Which panels would be drawn is Blender's own answer: every registered Properties panel of the
tab (bl_context) whose poll() is true for a context holding the light/world/material, whose
COMPAT_ENGINES (if it has one) holds PRISM, and whose parent panel is drawn too. What they draw
is recorded by calling each panel's real draw_header()/draw() with a stand-in UILayout that
logs prop()/template_*()/operator() calls (a window-less Blender cannot draw a real layout);
prop() checks that the property exists, as Blender's drawing would.
"""

import os
import sys
import time
import types

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
import bpy  # noqa: E402

import common as C  # noqa: E402
from runner_util import run_tests  # noqa: E402

V5 = bpy.app.version >= (5, 0, 0)


def all_panels():
    seen, todo = [], list(bpy.types.Panel.__subclasses__())
    while todo:
        c = todo.pop()
        if c not in seen:
            seen.append(c)
            todo.extend(c.__subclasses__())
    return [c for c in seen if getattr(c, "is_registered", False)]


def compat_snapshot():
    return {c: frozenset(c.COMPAT_ENGINES) for c in all_panels() if isinstance(getattr(c, "COMPAT_ENGINES", None), set)}


BEFORE = compat_snapshot()  # before the add-on is enabled
T0 = time.perf_counter()
prism = C.enable_addon()


class Layout:
    """Stands in for bpy.types.UILayout: every sub-layout is this object, every call is logged."""

    def __init__(self, log):
        object.__setattr__(self, "log", log)

    def __setattr__(self, name, value):  # use_property_split, active, enabled, alignment, ...
        pass

    def prop(self, data, prop, **kw):
        rna = data.bl_rna.properties.get(prop)
        if rna is None:
            raise AssertionError("draws %s.%s, which this Blender does not have" % (type(data).__name__, prop))
        self.log.append(("prop", data, prop, kw.get("text", rna.name), rna.type))
        return None

    def __getattr__(self, name):
        def call(*args, **kw):
            self.log.append((name,) + args + (kw,))
            if name == "panel":  # Blender 4.2+: (header, body)
                return self, self
            return self

        return call


class Space:
    """context.space_data of a Properties editor without a pinned ID."""

    type = "PROPERTIES"
    pin_id = None
    use_pin_id = False


class Context:
    """The Properties editor's context for one object: what its members would hold."""

    DATA = ("light", "camera", "mesh", "curve", "curves", "lattice", "armature", "meta_ball", "speaker",
            "lightprobe", "volume", "pointcloud", "grease_pencil", "gpencil", "world", "material",
            "material_slot", "texture", "texture_slot", "particle_system", "particle_settings", "bone",
            "edit_bone", "pose_bone", "line_style", "brush", "collision", "cloth", "soft_body", "fluid",
            "dynamic_paint", "rigid_body", "rigid_body_constraint", "collection", "id")

    def __init__(self, ob=None, **members):
        sc = bpy.context.scene
        d = dict.fromkeys(self.DATA)
        d.update(scene=sc, engine=sc.render.engine, object=ob, active_object=ob, space_data=Space(),
                 view_layer=bpy.context.view_layer, mode="OBJECT")
        if ob is not None:
            if ob.type == "LIGHT":
                d["light"] = ob.data
            elif ob.type == "CAMERA":
                d["camera"] = ob.data
            elif ob.type == "MESH":
                d["mesh"] = ob.data
            if ob.material_slots:
                d["material_slot"] = ob.material_slots[ob.active_material_index]
                d["material"] = ob.active_material
        d["world"] = sc.world
        d.update(members)
        self.__dict__.update(d)

    def __getattr__(self, name):  # preferences, window_manager, ...
        return getattr(bpy.context, name)

    def path_resolve(self, path):
        v = self
        for part in path.split("."):
            v = getattr(v, part)
        return v


class Self:
    """`self` for a panel's draw(): the panel class's attributes and methods, our layout."""

    def __init__(self, cls, layout):
        self.layout = layout
        self._cls = cls

    def __getattr__(self, name):
        raw = next((k.__dict__[name] for k in self._cls.__mro__ if name in k.__dict__), None)
        if isinstance(raw, (staticmethod, classmethod)):
            return raw.__get__(None, self._cls)
        if isinstance(raw, types.FunctionType):
            return raw.__get__(self)
        return getattr(self._cls, name)


def ours(cls):
    return cls.__module__.split(".")[0] == "prism"


def polls(cls, ctx):
    """Blender's rule for showing a panel: poll() (an exception counts as False, as in Blender;
    ours must not raise), COMPAT_ENGINES if any, and the parent shown."""
    engines = getattr(cls, "COMPAT_ENGINES", None)
    if engines is not None and ctx.engine not in engines:
        return False
    poll = getattr(cls, "poll", None)
    if poll is not None:
        try:
            if not poll(ctx):
                return False
        except Exception:
            if ours(cls):
                raise
            return False
    parent = getattr(cls, "bl_parent_id", "")
    if parent:
        pcls = getattr(bpy.types, parent, None)
        return pcls is not None and polls(pcls, ctx)
    return True


def shown_panels(tab, ctx):
    return [c for c in all_panels()
            if getattr(c, "bl_space_type", "") == "PROPERTIES" and getattr(c, "bl_context", "") == tab and polls(c, ctx)]


def draw(tab, ctx):
    """(panel names, log of what they draw) for the tab."""
    panels = shown_panels(tab, ctx)
    log = []
    for c in panels:
        for fn in ("draw_header", "draw"):
            f = getattr(c, fn, None)
            if f is None:
                continue
            try:
                f(Self(c, Layout(log)), ctx)
            except AssertionError:
                raise
            except Exception as e:
                if ours(c) or not c.__name__.endswith(("custom_props", "_animation")):
                    raise AssertionError("%s.%s raised %r" % (c.__name__, fn, e))
                print("  note: %s.%s: %r (Blender's, without a window)" % (c.__name__, fn, e))
    return sorted(c.__name__ for c in panels), log


def props(log, data):
    return {e[2] for e in log if e[0] == "prop" and e[1] == data}


def calls(log, name):
    return [e for e in log if e[0] == name]


def light_object(kind):
    C.reset()
    sc = bpy.context.scene
    sc.render.engine = "PRISM"
    data = bpy.data.lights.new(kind.title(), kind)
    ob = bpy.data.objects.new(kind.title(), data)
    sc.collection.objects.link(ob)
    return ob


def check_no_engine_specific(names):
    foreign = [n for n in names if n.startswith(("CYCLES_", "EEVEE_WORLD", "DATA_PT_EEVEE", "RENDER_PT_eevee"))]
    C.check(not foreign, "no Cycles/EEVEE-only panel among them: %s" % foreign)


def check_light_common(kind, ob, names, log):
    light = ob.data
    p = props(log, light)
    print("  %s: panels %s; light properties %s" % (kind, names, sorted(p)), flush=True)
    C.check("DATA_PT_prism_light" in names, "%s: Prism's Light panel is drawn" % kind)
    C.check({"color", "energy", "type"} <= p, "%s: Color, Power/Strength and the type are drawn" % kind)
    C.check(len([e for e in log if e[0] == "prop" and e[2] == "type"]) == 1,
            "%s: the light type is drawn once (not by Blender's DATA_PT_light as well)" % kind)
    ids = [(e[1], e[2]) for e in calls(log, "template_ID")]
    C.check((ob, "data") in ids, "%s: the light datablock browser (DATA_PT_context_light)" % kind)
    if V5:
        C.check({"use_temperature", "temperature", "exposure"} <= p, "%s: Temperature and Exposure (5.0)" % kind)
    check_no_engine_specific(names)


def test_point_light():
    ob = light_object("POINT")
    names, log = draw("data", Context(ob))
    check_light_common("point", ob, names, log)
    p = props(log, ob.data)
    C.check("shadow_soft_size" in p, "point: Radius (shadow_soft_size)")
    radius = [e[3] for e in log if e[0] == "prop" and e[2] == "shadow_soft_size"]
    C.check(radius == ["Radius"], "point: labelled Radius (%s)" % radius)
    C.check(("use_soft_falloff" in p) == hasattr(ob.data, "use_soft_falloff"), "point: Soft Falloff where Blender has it")
    C.check("spot_size" not in p and "angle" not in p and "size" not in p, "point: no spot/sun/area settings")


def test_spot_light():
    ob = light_object("SPOT")
    names, log = draw("data", Context(ob))
    check_light_common("spot", ob, names, log)
    p = props(log, ob.data)
    C.check({"shadow_soft_size", "spot_size", "spot_blend", "show_cone"} <= p, "spot: Radius, spot Size, Blend, Show Cone")
    C.check("DATA_PT_prism_light_beam_shape" in names, "spot: the Beam Shape subpanel is drawn")


def test_sun_light():
    ob = light_object("SUN")
    names, log = draw("data", Context(ob))
    check_light_common("sun", ob, names, log)
    p = props(log, ob.data)
    C.check("angle" in p and "shadow_soft_size" not in p, "sun: Angle, no Radius")
    strength = [e[3] for e in log if e[0] == "prop" and e[2] == "energy"]
    C.check(strength == ["Strength"], "sun: energy is labelled Strength (%s)" % strength)


def test_area_light():
    ob = light_object("AREA")
    ob.data.shape = "RECTANGLE"
    names, log = draw("data", Context(ob))
    check_light_common("area", ob, names, log)
    p = props(log, ob.data)
    C.check({"shape", "size", "size_y"} <= p, "area (rectangle): Shape, Size X, Size Y")
    C.check(("spread" in p) == hasattr(ob.data, "spread"), "area: Spread where Blender has it")
    power = [e[3] for e in log if e[0] == "prop" and e[2] == "energy"]
    C.check(power == ["Power"], "area: energy is labelled Power (%s)" % power)
    ob.data.shape = "DISK"
    names, log = draw("data", Context(ob))
    p = props(log, ob.data)
    C.check("size" in p and "size_y" not in p, "area (disk): Size only")


def test_light_nodes():
    ob = light_object("POINT")
    names, log = draw("data", Context(ob))
    C.check("DATA_PT_prism_light_nodes" not in names, "no Nodes panel for a light without nodes")
    ob.data.use_nodes = True
    names, log = draw("data", Context(ob))
    views = calls(log, "template_node_view")
    C.check("DATA_PT_prism_light_nodes" in names and len(views) == 1, "a light using nodes: the Nodes panel draws its tree")
    nt = ob.data.node_tree
    C.check(views[0][1] == nt and views[0][2].type == "OUTPUT_LIGHT" and views[0][3].name == "Surface",
            "the node view starts at the light output's Surface")


def test_world():
    C.reset()
    sc = bpy.context.scene
    sc.render.engine = "PRISM"
    sc.world = bpy.data.worlds.new("World")
    w = sc.world
    if not V5:
        w.use_nodes = True
    C.check(w.node_tree is not None, "the world has a node tree")
    names, log = draw("world", Context())
    print("  world panels:", names, flush=True)
    C.check("WORLD_PT_context_world" in names, "Blender's world browser (WORLD_PT_context_world)")
    ids = [(e[1], e[2], e[3].get("new")) for e in calls(log, "template_ID")]
    C.check((sc, "world", "world.new") in ids, "template_ID(scene, 'world', new='world.new')")
    views = calls(log, "template_node_view")
    out = w.node_tree.get_output_node("CYCLES")
    C.check(len(views) == 1 and views[0][1] == w.node_tree and views[0][2] == out and views[0][3].name == "Surface",
            "the Surface panel draws the world output's Surface tree")
    C.check(any(n.endswith("custom_props") for n in names), "custom properties")
    check_no_engine_specific(names)
    if not V5:  # 3.x: a world without nodes shows its colour (what the export reads then)
        w.use_nodes = False
        names, log = draw("world", Context())
        C.check("color" in props(log, w) and not calls(log, "template_node_view"), "3.x, no nodes: the world Color")
        C.check("use_nodes" in props(log, w), "3.x: the Use Nodes toggle")


def material_scene():
    C.reset()
    sc = bpy.context.scene
    sc.render.engine = "PRISM"
    red = C.material("Red", "ShaderNodeBsdfDiffuse", (0.8, 0.1, 0.1))
    blue = C.material("Blue", "ShaderNodeBsdfDiffuse", (0.1, 0.1, 0.8))
    ob = C.mesh_object("Cube", C.cube(1.0), red)
    ob.data.materials.append(blue)
    ob.active_material_index = 1
    return ob, blue


def test_material():
    ob, blue = material_scene()
    names, log = draw("material", Context(ob))
    print("  material panels:", names, flush=True)
    lists = calls(log, "template_list")
    C.check(any(e[3] == ob and e[4] == "material_slots" and e[6] == "active_material_index" for e in lists),
            "the material slot list (template_list of material_slots)")
    ops = {e[1] for e in calls(log, "operator")}
    C.check({"object.material_slot_add", "object.material_slot_remove"} <= ops, "slot add/remove buttons")
    C.check(calls(log, "menu"), "the slot specials menu")
    ids = [(e[1], e[2], e[3].get("new")) for e in calls(log, "template_ID")]
    C.check((ob, "active_material", "material.new") in ids, "browse/new: template_ID(ob, 'active_material', new='material.new')")
    views = calls(log, "template_node_view")
    C.check(len(views) == 1 and views[0][1] == blue.node_tree and views[0][2].type == "OUTPUT_MATERIAL"
            and views[0][3].name == "Surface", "the Surface panel draws the active slot's material output tree")
    C.check("use_backface_culling" in props(log, blue), "Settings: Backface Culling (the glTF doubleSided the export writes)")
    C.check("sss_mode" in props(log, blue.prism), "Prism's own material settings")
    check_no_engine_specific(names)
    # Edit mode: Assign/Select/Deselect, as every engine's slot panel.
    bpy.context.view_layer.objects.active = ob
    bpy.ops.object.mode_set(mode="EDIT")
    try:
        names, log = draw("material", Context(ob, mode="EDIT_MESH"))
        ops = {e[1] for e in calls(log, "operator")}
        C.check({"object.material_slot_assign", "object.material_slot_select", "object.material_slot_deselect"} <= ops,
                "edit mode: Assign, Select, Deselect")
    finally:
        bpy.ops.object.mode_set(mode="OBJECT")
    if not V5:
        blue.use_nodes = False
        names, log = draw("material", Context(ob))
        C.check({"diffuse_color", "metallic", "roughness"} <= props(log, blue), "3.x, no nodes: Base Color, Metallic, Roughness")


def test_camera_object_output():
    sc = C.simple_scene()
    sc.render.engine = "PRISM"
    cam = sc.camera
    names, log = draw("data", Context(cam))
    p = props(log, cam.data)
    d = props(log, cam.data.dof)
    C.check({"lens", "type", "clip_start", "clip_end", "sensor_width"} <= p, "camera: Lens (focal length, clipping) and sensor")
    C.check({"use_dof", "focus_object", "focus_distance", "aperture_fstop"} <= d, "camera: Depth of Field and its F-Stop")
    check_no_engine_specific(names)
    ball = bpy.data.objects["Ball"]
    names, log = draw("object", Context(ball))
    C.check("hide_render" in props(log, ball), "object: Visibility (Show in Renders)")
    names, log = draw("output", Context(ball))
    C.check({"resolution_x", "resolution_percentage"} <= props(log, sc.render), "output: Format (resolution)")
    C.check({"frame_start", "frame_end"} <= props(log, sc), "output: Frame Range")
    names, log = draw("render", Context(ball))
    C.check("view_transform" in props(log, sc.view_settings), "render: Color Management")


def test_render_labels_fit():
    """Prism's render settings: every label left of a value (non-boolean, with property split) is
    at most as long as Cycles' "Noise Threshold", which fits the default editor width; the
    wavelength density was "Wavelength Density", cut off there."""
    sc = C.simple_scene()
    sc.render.engine = "PRISM"
    sc.prism.use_denoising = True
    names, log = draw("render", Context())
    labels = [(e[2], e[3]) for e in log if e[0] == "prop" and e[1] == sc.prism and e[4] != "BOOLEAN" and e[3]]
    print("  labels:", labels, flush=True)
    C.check(("wavelength_pdf", "Density") in labels, "the wavelength density is labelled Density")
    long = [lab for _, lab in labels if len(lab) > len("Noise Threshold")]
    C.check(not long, "no label longer than 'Noise Threshold': %s" % long)


def test_unregister_restores_compat_engines():
    """Disabling the add-on removes PRISM from exactly the panels it was added to."""
    added = sorted(c.__name__ for c, e in compat_snapshot().items() if "PRISM" in e and c in BEFORE and "PRISM" not in BEFORE[c])
    C.check(len(added) > 50 and "EEVEE_MATERIAL_PT_context_material" in added and "DATA_PT_context_light" in added,
            "enabled: PRISM added to %d built-in panels" % len(added))
    C.check("DATA_PT_light" not in added and "VIEWLAYER_PT_layer_passes" not in added, "not to the replaced ones")
    import addon_utils

    addon_utils.disable("prism", default_set=True)
    after = compat_snapshot()
    still = sorted(c.__name__ for c, e in after.items() if "PRISM" in e)
    C.check(not still, "disabled: no panel lists PRISM (%s)" % still)
    changed = sorted(c.__name__ for c in BEFORE if c in after and after[c] != BEFORE[c])
    C.check(not changed, "every built-in panel's COMPAT_ENGINES is as before enabling (%s)" % changed)
    C.check(not any(ours(c) for c in all_panels()), "Prism's own panels are unregistered")
    C.enable_addon()  # a second enable/disable cycle works the same
    again = sorted(c.__name__ for c, e in compat_snapshot().items() if "PRISM" in e and c in BEFORE and not ours(c))
    C.check(again == added, "re-enabled: the same %d panels" % len(again))
    addon_utils.disable("prism", default_set=True)
    C.check(compat_snapshot() == {c: e for c, e in BEFORE.items() if c.is_registered}, "disabled again: as before")


if __name__ == "__main__":
    argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else ([] if bpy.app.background and "--python" in sys.argv else sys.argv[1:])
    sys.argv = [sys.argv[0]] + argv
    print("Blender %s" % bpy.app.version_string, flush=True)
    import atexit

    atexit.register(lambda: print("test_panels: %.1f s" % (time.perf_counter() - T0), flush=True))
    run_tests("panels (Blender %s)" % bpy.app.version_string, globals())

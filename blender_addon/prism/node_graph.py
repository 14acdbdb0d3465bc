# SPDX-License-Identifier: MIT
"""Blender shader node trees -> the material JSON's `graph` form (src/shading/parse.rs).

Links are followed through reroutes, muted nodes (their internal pass-through links, as
Blender evaluates them), muted links (the socket's own value) and node groups (into the group
and out of its Group Input). Every node or setting that cannot be translated is one warning
naming the material, the node and its type; the input then takes the value its slider shows,
which is what Blender itself would use without the link.
"""


# Blender Math / Vector Math operations the renderer implements (lower-case identifiers).
MATH_OPS = {
    "ADD", "SUBTRACT", "MULTIPLY", "DIVIDE", "MULTIPLY_ADD", "POWER", "LOGARITHM", "SQRT",
    "INVERSE_SQRT", "ABSOLUTE", "EXPONENT", "MINIMUM", "MAXIMUM", "LESS_THAN", "GREATER_THAN",
    "SIGN", "COMPARE", "SMOOTH_MIN", "SMOOTH_MAX", "ROUND", "FLOOR", "CEIL", "TRUNC", "FRACT",
    "MODULO", "FLOORED_MODULO", "WRAP", "SNAP", "PINGPONG", "SINE", "COSINE", "TANGENT",
    "ARCSINE", "ARCCOSINE", "ARCTANGENT", "ARCTAN2", "SINH", "COSH", "TANH", "RADIANS", "DEGREES",
}
VECTOR_MATH_OPS = {
    "ADD", "SUBTRACT", "MULTIPLY", "DIVIDE", "MULTIPLY_ADD", "CROSS_PRODUCT", "PROJECT",
    "REFLECT", "REFRACT", "FACEFORWARD", "DOT_PRODUCT", "DISTANCE", "LENGTH", "SCALE",
    "NORMALIZE", "SNAP", "FLOOR", "CEIL", "MODULO", "WRAP", "FRACTION", "ABSOLUTE", "MINIMUM",
    "MAXIMUM", "SINE", "COSINE", "TANGENT", "POWER", "SIGN",
}
BLEND_TYPES = {
    "MIX", "DARKEN", "MULTIPLY", "BURN", "LIGHTEN", "SCREEN", "DODGE", "ADD", "OVERLAY",
    "SOFT_LIGHT", "LINEAR_LIGHT", "DIFFERENCE", "EXCLUSION", "SUBTRACT", "DIVIDE", "HUE",
    "SATURATION", "COLOR", "VALUE",
}

# Node types whose value is a closure (a BSDF), not data: linking them into a data socket is
# not something the graph can evaluate.
SHADER_SOCKET = "SHADER"


class _GroupNeedsBake(Exception):
    """An untranslatable node inside a node group: the group's output that leads to it is
    baked instead (caught where the walk entered the group from the material's top level)."""

    def __init__(self, node):
        super().__init__(node.name)
        self.node = node


_NEEDS_BAKE = object()  # `_done` marker of a node inside a group that must be baked


def _const(sock):
    """The socket's own value as the JSON constant of its type."""
    v = getattr(sock, "default_value", None)
    if v is None:
        return 0.0
    try:
        vals = [float(x) for x in v]
    except TypeError:
        return float(v)
    if len(vals) == 2:
        vals.append(0.0)
    return vals[:4]


def _in(node, *names):
    """Input by name or identifier (spellings differ between Blender versions)."""
    for n in names:
        s = node.inputs.get(n)
        if s is not None:
            return s
        for s in node.inputs:
            if s.identifier == n:
                return s
    return None


def _curve_samples(node, default_range):
    """(mapping, lo, hi, 257 x positions) of a curve node: its clipping range, or
    `default_range` without clipping, sampled evenly as Cycles bakes curves."""
    cm = node.mapping
    try:
        cm.initialize()
    except Exception:
        pass
    lo, hi = float(cm.clip_min_x), float(cm.clip_max_x)
    if not cm.use_clip or hi <= lo:
        lo, hi = default_range
    return cm, lo, hi, [lo + (hi - lo) * k / 256.0 for k in range(257)]


class GraphBuilder:
    """Collects the graph of one material.

    `images(img) -> (file name, linear)` writes an image next to the JSON; `uv_set(name)` and
    `color_set(name)` give the TEXCOORD_n / COLOR_n set that carries a named UV map or colour
    attribute ("" = the active one); `warn(msg)` reports to the user. `bake(node, output,
    what)`, when given, registers a bake of a node output the graph cannot evaluate
    (`node_bake.py`; `what` names it for the messages) and returns the image name that stands
    for it; without it such nodes keep their inputs' own values, as before."""

    def __init__(self, material_name, images, uv_set, color_set, warn, bake=None):
        self.mat = material_name
        self.bake = bake
        self._baked = {}
        self.images = images
        self.uv_set = uv_set
        self.color_set = color_set
        self._warn = warn
        self.nodes = {}
        self.inputs = {}
        self._done = {}
        self._warned = set()

    def warn(self, node, what):
        key = (node.name if node is not None else "", what)
        if key in self._warned:
            return
        self._warned.add(key)
        if node is None:
            self._warn("material '%s': %s" % (self.mat, what))
        else:
            self._warn("material '%s': node '%s' (%s): %s" % (self.mat, node.name, node.bl_idname, what))

    # -- public
    def bind(self, key, sock, scale=None):
        """Binds material input `key` to what drives `sock` (if linked); `scale` multiplies."""
        if sock is None:
            return False
        v = self.value(sock, ())
        if not isinstance(v, dict):
            return False
        if scale is not None:
            name = "__scale_%s" % key
            self.nodes[name] = {"type": "math", "operation": "multiply", "inputs": {"a": v, "b": float(scale)}}
            v = {"node": name, "output": "value"}
        self.inputs[key] = v
        return True

    def bind_const(self, key, value):
        self.inputs[key] = value

    def result(self):
        linked = any(isinstance(v, dict) for v in self.inputs.values())
        if not self.inputs or not (linked or "alpha" in self.inputs):
            return None
        # World-space vectors (Geometry, Normal Map in world space, ...) in Blender's Z-up
        # frame, not the glTF file's Y-up one.
        return {"version": 1, "world_up": "z", "nodes": self.nodes, "inputs": self.inputs}

    # -- links
    def value(self, sock, ctx):
        """JSON value for input socket `sock` in group context `ctx` (a tuple of group nodes)."""
        link = self._live_link(sock)
        if link is None:
            return _const(sock)
        return self._output(link.from_node, link.from_socket, ctx, sock)

    @staticmethod
    def _live_link(sock):
        if not sock.is_linked:
            return None
        for link in sock.links:
            if not getattr(link, "is_muted", False) and getattr(link, "is_valid", True):
                return link
        return None

    def _upstream(self, sock):
        """(node, output socket) that drives input `sock`, or None when unlinked (or muted)."""
        link = self._live_link(sock)
        return None if link is None else (link.from_node, link.from_socket)

    def _output(self, node, out, ctx, target):
        """JSON value for output `out` of `node`, read by input socket `target`."""
        entry = None  # the top-level group node (and its output) this walk went into
        for _ in range(256):  # reroutes, muted nodes and group boundaries
            if node.type == "REROUTE":
                link = self._live_link(node.inputs[0])
                if link is None:
                    return _const(target)
                node, out = link.from_node, link.from_socket
                continue
            if getattr(node, "mute", False):
                src = None
                for il in getattr(node, "internal_links", []):
                    if il.to_socket == out:
                        src = il.from_socket
                if src is None:
                    return _const(target)
                up = self._upstream(src)
                if up is None:
                    return _const(src)
                node, out = up
                continue
            if node.type == "GROUP":
                if not ctx:
                    entry = (node, out)
                tree = node.node_tree
                gout = None
                for n in tree.nodes if tree is not None else []:
                    if n.type == "GROUP_OUTPUT" and (gout is None or n.is_active_output):
                        gout = n
                inner = None
                if gout is not None:
                    for s in gout.inputs:
                        if s.identifier == out.identifier:
                            inner = s
                if inner is None:
                    self.warn(node, "the group has no output '%s'" % out.name)
                    return _const(target)
                ctx = ctx + (node,)
                up = self._upstream(inner)
                if up is None:
                    return _const(inner)
                node, out = up
                continue
            if node.type == "GROUP_INPUT":
                if not ctx:
                    return _const(target)
                group = ctx[-1]
                ctx = ctx[:-1]
                outer = None
                for s in group.inputs:
                    if s.identifier == out.identifier:
                        outer = s
                if outer is None:
                    return _const(target)
                up = self._upstream(outer)
                if up is None:
                    return _const(outer)
                node, out = up
                continue
            break
        if node.type == "VALUE":
            return float(node.outputs[0].default_value)
        if node.type == "RGB":
            return [float(x) for x in node.outputs[0].default_value]
        if out.type == SHADER_SOCKET:
            self.warn(node, "a shader output feeds a colour or value input; its default is used")
            return _const(target)
        name = "/".join([g.name for g in ctx] + [node.name])
        try:
            if name not in self._done:
                self._done[name] = None  # a cycle reads the default below
                self._done[name] = self._node(node, ctx, name)
            outputs = self._done[name]
            if outputs is _NEEDS_BAKE:
                raise _GroupNeedsBake(node)
        except _GroupNeedsBake as e:
            self._done[name] = _NEEDS_BAKE if ctx else self._done.get(name)
            if entry is None:
                raise
            group, group_out = entry
            ref = self._bake_output(group, group_out, "node '%s' (%s) inside it is not supported" % (
                e.node.name, e.node.bl_idname))
            return _const(target) if ref is None else dict(ref, fallback=_const(target))
        if outputs is None:
            return _const(target)
        ours = outputs.get(out.identifier) or outputs.get(out.name)
        if ours is None:
            self.warn(node, "output '%s' is not supported; the input's default is used" % out.name)
            return _const(target)
        if isinstance(ours, (float, list)):
            return ours
        if isinstance(ours, dict):  # a baked output (`_bake_output`)
            return dict(ours, fallback=_const(target))
        return {"node": name, "output": ours}

    def _bake_output(self, node, out, why):
        """A reference to an image node holding output `out` of top-level node `node` baked
        by Cycles, or None (warned) when it cannot be baked. References carry the reading
        socket's own value as "fallback", for meshes the bake cannot cover (`resolve_bakes`)."""
        key = (node.name, out.identifier)
        if key in self._baked:
            return self._baked[key]
        from .node_bake import why_not_bakeable

        ref = None
        reason = why_not_bakeable(node, out)
        if reason is not None:
            self.warn(node, "%s, and its output '%s' cannot be baked (%s); the input it feeds uses its own value"
                      % (why, out.name, reason))
        else:
            # The exporter says what became of it once it knows (`Exporter._run_bakes`): baked,
            # or why not (a mesh without UVs, a failed bake).
            image = self.bake(node, out, "material '%s': node '%s' (%s): %s" % (self.mat, node.name, node.bl_idname, why))
            bname = "%s/bake:%s" % (node.name, out.identifier)
            self.nodes[bname] = {"type": "image_texture", "image": image, "color_space": "linear",
                                 "interpolation": "linear", "extension": "extend", "inputs": {}}
            ref = {"node": bname, "output": "color"}
        self._baked[key] = ref
        return ref

    # -- nodes
    def _inputs(self, node, ctx, mapping):
        """{our input: JSON value} for {our input: Blender socket}."""
        out = {}
        for ours, sock in mapping.items():
            if sock is not None:
                out[ours] = self.value(sock, ctx)
        return out

    def _node(self, node, ctx, name):
        """Emits `node` as JSON node `name`; returns {Blender output: our output} or None."""
        t = node.type
        j = None
        outs = None
        I = lambda *n: _in(node, *n)  # noqa: E731
        if t == "TEX_COORD":
            if getattr(node, "object", None) is not None:
                self.warn(node, "coordinates from another object are not supported; this object's are used")
            if node.outputs["Camera"].is_linked or node.outputs["Window"].is_linked:
                self.warn(node, "Camera and Window coordinates are not supported (read as 0)")
            j = {"type": "tex_coord"}
            outs = {"Generated": "generated", "Normal": "normal", "UV": "uv", "Object": "object", "Reflection": "reflection",
                    "Camera": [0.0, 0.0, 0.0], "Window": [0.0, 0.0, 0.0]}
        elif t == "UVMAP":
            if getattr(node, "from_instancer", False):
                self.warn(node, "UVs from the instancer are not supported")
            j = {"type": "uv_map", "set": self.uv_set(node.uv_map)}
            outs = {"UV": "uv"}
        elif t == "VERTEX_COLOR":
            j = {"type": "color_attribute", "set": self.color_set(node.layer_name)}
            outs = {"Color": "color", "Alpha": "alpha"}
        elif t == "NEW_GEOMETRY":
            j = {"type": "geometry"}
            outs = {"Position": "position", "Normal": "normal", "True Normal": "true_normal", "Incoming": "incoming",
                    "Backfacing": "backfacing"}
        elif t == "LIGHT_PATH":
            j = {"type": "light_path"}
            outs = {"Is Camera Ray": "is_camera_ray"}
        elif t == "FRESNEL":
            j = {"type": "fresnel", "inputs": self._inputs(node, ctx, {"ior": I("IOR")})}
            if I("Normal").is_linked:
                j["inputs"]["normal"] = self.value(I("Normal"), ctx)
            outs = {"Fac": "fac"}
        elif t == "LAYER_WEIGHT":
            j = {"type": "layer_weight", "inputs": self._inputs(node, ctx, {"blend": I("Blend")})}
            if I("Normal").is_linked:
                j["inputs"]["normal"] = self.value(I("Normal"), ctx)
            outs = {"Fresnel": "fresnel", "Facing": "facing"}
        elif t == "MAPPING":
            m = {"vector": I("Vector"), "location": I("Location"), "rotation": I("Rotation"), "scale": I("Scale")}
            j = {"type": "mapping", "vector_type": node.vector_type.lower(), "inputs": self._inputs(node, ctx, m)}
            outs = {"Vector": "vector"}
        elif t == "TEX_IMAGE":
            j = self._image_node(node, ctx)
            outs = {"Color": "color", "Alpha": "alpha"} if j is not None else None
        elif t == "MATH":
            if node.operation not in MATH_OPS:
                self.warn(node, "operation %s is not supported" % node.operation)
                return None
            ins = list(node.inputs)
            j = {"type": "math", "operation": node.operation.lower(), "clamp": bool(node.use_clamp),
                 "inputs": self._inputs(node, ctx, {"a": ins[0], "b": ins[1], "c": ins[2] if len(ins) > 2 else None})}
            outs = {"Value": "value"}
        elif t == "VECT_MATH":
            if node.operation not in VECTOR_MATH_OPS:
                self.warn(node, "operation %s is not supported" % node.operation)
                return None
            ins = list(node.inputs)
            m = {"a": ins[0], "b": ins[1], "c": ins[2] if len(ins) > 2 else None, "scale": I("Scale")}
            j = {"type": "vector_math", "operation": node.operation.lower(), "inputs": self._inputs(node, ctx, m)}
            outs = {"Vector": "vector", "Value": "value"}
        elif t == "MIX":  # 3.4+ Mix node
            dt = node.data_type
            if dt not in {"FLOAT", "VECTOR", "RGBA"}:
                self.warn(node, "data type %s is not supported" % dt)
                return None
            if dt == "VECTOR" and getattr(node, "factor_mode", "UNIFORM") != "UNIFORM":
                self.warn(node, "a non-uniform factor is not supported; its average is used")
            suffix = {"FLOAT": "Float", "VECTOR": "Vector", "RGBA": "Color"}[dt]
            fac = I("Factor_Float") if dt != "VECTOR" or getattr(node, "factor_mode", "UNIFORM") == "UNIFORM" else I("Factor_Vector")
            m = {"factor": fac, "a": I("A_" + suffix), "b": I("B_" + suffix)}
            j = {"type": "mix", "data_type": dt.lower(), "blend_type": node.blend_type.lower(),
                 "clamp_factor": bool(node.clamp_factor), "clamp_result": bool(getattr(node, "clamp_result", False)),
                 "inputs": self._inputs(node, ctx, m)}
            outs = {"Result_" + suffix: "result"}
        elif t == "MIX_RGB":
            m = {"factor": I("Fac"), "a": I("Color1"), "b": I("Color2")}
            j = {"type": "mix", "data_type": "rgba", "blend_type": node.blend_type.lower(), "clamp_factor": True,
                 "clamp_result": bool(node.use_clamp), "inputs": self._inputs(node, ctx, m)}
            outs = {"Color": "result"}
        elif t == "INVERT":
            j = {"type": "invert", "inputs": self._inputs(node, ctx, {"fac": I("Fac"), "color": I("Color")})}
            outs = {"Color": "color"}
        elif t == "HUE_SAT":
            m = {"hue": I("Hue"), "saturation": I("Saturation"), "value": I("Value"), "fac": I("Fac"), "color": I("Color")}
            j = {"type": "hue_saturation", "inputs": self._inputs(node, ctx, m)}
            outs = {"Color": "color"}
        elif t == "BRIGHTCONTRAST":
            m = {"color": I("Color"), "bright": I("Bright"), "contrast": I("Contrast")}
            j = {"type": "bright_contrast", "inputs": self._inputs(node, ctx, m)}
            outs = {"Color": "color"}
        elif t == "GAMMA":
            j = {"type": "gamma", "inputs": self._inputs(node, ctx, {"color": I("Color"), "gamma": I("Gamma")})}
            outs = {"Color": "color"}
        elif t == "RGBTOBW":
            j = {"type": "rgb_to_bw", "inputs": self._inputs(node, ctx, {"color": I("Color")})}
            outs = {"Val": "val"}
        elif t in {"SEPARATE_COLOR", "SEPRGB", "SEPHSV"}:
            mode = node.mode.lower() if t == "SEPARATE_COLOR" else ("rgb" if t == "SEPRGB" else "hsv")
            j = {"type": "separate_color", "mode": mode, "inputs": self._inputs(node, ctx, {"color": I("Color", "Image")})}
            outs = {"Red": "red", "Green": "green", "Blue": "blue", "R": "red", "G": "green", "B": "blue",
                    "H": "red", "S": "green", "V": "blue"}
        elif t in {"COMBINE_COLOR", "COMBRGB", "COMBHSV"}:
            mode = node.mode.lower() if t == "COMBINE_COLOR" else ("rgb" if t == "COMBRGB" else "hsv")
            ins = list(node.inputs)
            j = {"type": "combine_color", "mode": mode,
                 "inputs": self._inputs(node, ctx, {"red": ins[0], "green": ins[1], "blue": ins[2]})}
            outs = {"Color": "color", "Image": "color"}
        elif t == "SEPXYZ":
            j = {"type": "separate_xyz", "inputs": self._inputs(node, ctx, {"vector": I("Vector")})}
            outs = {"X": "x", "Y": "y", "Z": "z"}
        elif t == "COMBXYZ":
            j = {"type": "combine_xyz", "inputs": self._inputs(node, ctx, {"x": I("X"), "y": I("Y"), "z": I("Z")})}
            outs = {"Vector": "vector"}
        elif t == "MAP_RANGE":
            if getattr(node, "data_type", "FLOAT") != "FLOAT":
                self.warn(node, "vector Map Range is not supported")
                return None
            ins = list(node.inputs)
            m = dict(zip(["value", "from_min", "from_max", "to_min", "to_max", "steps"], ins[:6]))
            j = {"type": "map_range", "interpolation": node.interpolation_type.lower(), "clamp": bool(node.clamp),
                 "inputs": self._inputs(node, ctx, m)}
            outs = {"Result": "result"}
        elif t == "CLAMP":
            m = {"value": I("Value"), "min": I("Min"), "max": I("Max")}
            j = {"type": "clamp", "clamp_type": node.clamp_type.lower(), "inputs": self._inputs(node, ctx, m)}
            outs = {"Result": "result"}
        elif t == "VALTORGB":
            ramp = node.color_ramp
            if ramp.color_mode != "RGB":
                self.warn(node, "colour mode %s is not supported; the stops are blended in RGB" % ramp.color_mode)
            stops = [[float(e.position), [float(c) for c in e.color]] for e in ramp.elements]
            j = {"type": "color_ramp", "interpolation": ramp.interpolation.lower(), "stops": stops,
                 "inputs": self._inputs(node, ctx, {"fac": I("Fac")})}
            outs = {"Color": "color", "Alpha": "alpha"}
        elif t == "TEX_CHECKER":
            m = {"color1": I("Color1"), "color2": I("Color2"), "scale": I("Scale")}
            j = {"type": "checker_texture", "inputs": self._inputs(node, ctx, m)}
            if I("Vector").is_linked:
                j["inputs"]["vector"] = self.value(I("Vector"), ctx)
            outs = {"Color": "color", "Fac": "fac"}
        elif t == "TEX_GRADIENT":
            j = {"type": "gradient_texture", "gradient_type": node.gradient_type.lower(), "inputs": {}}
            if I("Vector").is_linked:
                j["inputs"]["vector"] = self.value(I("Vector"), ctx)
            outs = {"Color": "color", "Fac": "fac"}
        elif t == "TEX_NOISE":
            dims = int(getattr(node, "noise_dimensions", "3D")[0])
            kind = getattr(node, "noise_type", "FBM").lower()  # 4.1+; fBM before
            m = {"w": I("W"), "scale": I("Scale"), "detail": I("Detail"), "roughness": I("Roughness"),
                 "lacunarity": I("Lacunarity"), "offset": I("Offset"), "gain": I("Gain"), "distortion": I("Distortion")}
            # Blender 3.x: no Lacunarity (2) and its fBM is always normalised; its
            # Roughness is clamped to [0, 1].
            j = {"type": "noise_texture", "dimensions": dims, "noise_type": kind,
                 "normalize": bool(getattr(node, "normalize", True)), "inputs": self._inputs(node, ctx, m)}
            if I("Lacunarity") is None and not I("Roughness").is_linked:
                j["inputs"]["roughness"] = min(max(float(I("Roughness").default_value), 0.0), 1.0)
            if I("Vector").is_linked:
                j["inputs"]["vector"] = self.value(I("Vector"), ctx)
            outs = {"Fac": "fac", "Color": "color"}
        elif t == "TEX_VORONOI":
            dims = int(getattr(node, "voronoi_dimensions", "3D")[0])
            m = {"w": I("W"), "scale": I("Scale"), "detail": I("Detail"), "roughness": I("Roughness"),
                 "lacunarity": I("Lacunarity"), "smoothness": I("Smoothness"), "exponent": I("Exponent"),
                 "randomness": I("Randomness")}
            j = {"type": "voronoi_texture", "dimensions": dims, "feature": node.feature.lower(),
                 "distance": node.distance.lower(), "normalize": bool(getattr(node, "normalize", False)),
                 "inputs": self._inputs(node, ctx, m)}
            if I("Detail") is None:  # Blender < 4.0: one octave
                j["inputs"]["detail"] = 0.0
            if I("Vector").is_linked:
                j["inputs"]["vector"] = self.value(I("Vector"), ctx)
            outs = {"Distance": "distance", "Color": "color", "Position": "position", "W": "w", "Radius": "radius"}
        elif t in {"CURVE_RGB", "CURVE_FLOAT"}:
            j = self._curves_node(node, ctx, t == "CURVE_RGB")
            outs = {"Color": "color", "Value": "value"} if j is not None else None
        elif t == "CURVE_VEC":
            j = self._vector_curves_node(node, ctx)
            outs = {"Vector": "vector"}
        elif t == "BLACKBODY":
            j = {"type": "blackbody", "inputs": self._inputs(node, ctx, {"temperature": I("Temperature")})}
            outs = {"Color": "color"}
        elif t == "WAVELENGTH":
            j = {"type": "wavelength", "inputs": self._inputs(node, ctx, {"wavelength": I("Wavelength")})}
            outs = {"Color": "color"}
        elif t == "NORMAL_MAP":
            if node.space not in {"TANGENT", "OBJECT", "WORLD", "BLENDER_OBJECT", "BLENDER_WORLD"}:
                self.warn(node, "%s space is not supported; the normal is left unperturbed" % node.space)
                return None
            if node.space == "TANGENT" and node.uv_map:
                self.warn(node, "the UV map '%s' is not used for tangents; the active UV map is" % node.uv_map)
            j = {"type": "normal_map", "space": node.space.lower(),
                 "inputs": self._inputs(node, ctx, {"strength": I("Strength"), "color": I("Color")})}
            outs = {"Normal": "normal"}
        elif t == "BUMP":
            m = {"strength": I("Strength"), "distance": I("Distance"), "height": I("Height")}
            j = {"type": "bump", "invert": bool(node.invert), "inputs": self._inputs(node, ctx, m)}
            # Filter Width (Blender 4.5+; a fixed value) counts the offsets to the two nearby
            # points in pixels. Earlier Cycles offset by the whole ray differential: 1 pixel,
            # the value Blender's versioning gives older files (Noise bump against 3.4's
            # Cycles: pattern correlation 0.993, 0.898 at 0.1).
            fw = node.inputs.get("Filter Width")
            if fw is None:
                j["filter_width"] = 1.0
            else:
                if fw.is_linked:
                    self.warn(node, "a linked Filter Width is not supported (Blender takes a fixed value too); its own value is used")
                j["filter_width"] = max(float(fw.default_value), 1e-4)
            if I("Normal").is_linked:
                j["inputs"]["normal"] = self.value(I("Normal"), ctx)
            outs = {"Normal": "normal"}
        elif t == "TEX_WAVE":
            rings = node.wave_type == "RINGS"
            direction = (node.rings_direction if rings else node.bands_direction).lower()
            m = {"scale": I("Scale"), "distortion": I("Distortion"), "detail": I("Detail"),
                 "detail_scale": I("Detail Scale"), "detail_roughness": I("Detail Roughness"),
                 "phase_offset": I("Phase Offset")}
            j = {"type": "wave_texture", "wave_type": "rings" if rings else "bands", "direction": direction,
                 "wave_profile": node.wave_profile.lower(), "inputs": self._inputs(node, ctx, m)}
            if I("Vector").is_linked:
                j["inputs"]["vector"] = self.value(I("Vector"), ctx)
            outs = {"Color": "color", "Fac": "fac"}
        elif t == "TEX_MAGIC":
            j = {"type": "magic_texture", "depth": int(node.turbulence_depth),
                 "inputs": self._inputs(node, ctx, {"scale": I("Scale"), "distortion": I("Distortion")})}
            if I("Vector").is_linked:
                j["inputs"]["vector"] = self.value(I("Vector"), ctx)
            outs = {"Color": "color", "Fac": "fac"}
        elif t == "TEX_BRICK":
            m = {"color1": I("Color1"), "color2": I("Color2"), "mortar": I("Mortar"), "scale": I("Scale"),
                 "mortar_size": I("Mortar Size"), "mortar_smooth": I("Mortar Smooth"), "bias": I("Bias"),
                 "brick_width": I("Brick Width"), "row_height": I("Row Height")}
            j = {"type": "brick_texture", "offset": float(node.offset), "offset_frequency": int(node.offset_frequency),
                 "squash": float(node.squash), "squash_frequency": int(node.squash_frequency),
                 "inputs": self._inputs(node, ctx, m)}
            if I("Vector").is_linked:
                j["inputs"]["vector"] = self.value(I("Vector"), ctx)
            outs = {"Color": "color", "Fac": "fac"}
        elif t == "TEX_WHITE_NOISE":
            dims = int(getattr(node, "noise_dimensions", "3D")[0])
            j = {"type": "white_noise_texture", "dimensions": dims, "inputs": self._inputs(node, ctx, {"w": I("W")})}
            if I("Vector").is_linked:
                j["inputs"]["vector"] = self.value(I("Vector"), ctx)
            outs = {"Value": "value", "Color": "color"}
        elif self.bake is not None and ctx:
            raise _GroupNeedsBake(node)
        elif self.bake is not None:
            outs = {}
            for o in node.outputs:
                if o.is_linked and o.type != SHADER_SOCKET:
                    ref = self._bake_output(node, o, "not supported")
                    if ref is not None:
                        outs[o.identifier] = ref
            return outs or None
        else:
            self.warn(node, "not supported; the input it feeds uses its own value")
            return None
        if getattr(node, "texture_mapping", None) is not None and t.startswith("TEX_"):
            tm = node.texture_mapping
            moved = any(abs(x) > 1e-9 for x in tm.translation) or any(abs(x) > 1e-9 for x in tm.rotation) or any(
                abs(x - 1.0) > 1e-9 for x in tm.scale)
            if moved:
                self.warn(node, "the node's own texture mapping (N panel) is not supported; use a Mapping node")
        self.nodes[name] = j
        return outs

    def _curves_node(self, node, ctx, rgb):
        """RGB Curves / Float Curve as tables of 257 samples over the curve's clipping range, as
        Cycles bakes them (RGB: each channel's curve after the combined one, as Blender's
        curvemapping_evaluate_premulRGBF)."""
        cm, lo, hi, xs = _curve_samples(node, (0.0, 1.0))
        curves = list(cm.curves)
        tables = []
        if rgb:
            combined = curves[3]
            for c in curves[:3]:
                vals = [float(cm.evaluate(c, cm.evaluate(combined, x))) for x in xs]
                tables.append({"lo": lo, "hi": hi, "values": vals, "extrapolate": cm.extend == "EXTRAPOLATED"})
            m = {"fac": _in(node, "Fac", "Factor"), "color": _in(node, "Color")}
        else:
            c = curves[0]
            tables.append({"lo": lo, "hi": hi, "values": [float(cm.evaluate(c, x)) for x in xs],
                           "extrapolate": cm.extend == "EXTRAPOLATED"})
            m = {"fac": _in(node, "Factor", "Fac"), "value": _in(node, "Value")}
        return {"type": "curves", "tables": tables, "inputs": self._inputs(node, ctx, m)}

    def _vector_curves_node(self, node, ctx):
        """Vector Curves: one 257-sample table per axis over the curve's clipping range
        ([-1, 1] by default), as Cycles bakes them."""
        cm, lo, hi, xs = _curve_samples(node, (-1.0, 1.0))
        tables = [{"lo": lo, "hi": hi, "values": [float(cm.evaluate(c, x)) for x in xs],
                   "extrapolate": cm.extend == "EXTRAPOLATED"} for c in list(cm.curves)[:3]]
        m = {"fac": _in(node, "Fac", "Factor"), "vector": _in(node, "Vector")}
        return {"type": "vector_curves", "tables": tables, "inputs": self._inputs(node, ctx, m)}

    def _image_node(self, node, ctx):
        img = node.image
        if img is None:
            self.warn(node, "no image; rendered black as in Cycles")
            return None
        if img.source not in {"FILE", "GENERATED"}:
            self.warn(node, "image source %s is not supported (only still images); its current frame is used" % img.source)
        if node.projection != "FLAT":
            self.warn(node, "projection %s is not supported; flat is used" % node.projection)
        try:
            fname, linear = self.images(img)
        except Exception as e:  # an unreadable image: magenta, as Blender shows it
            self.warn(node, "image '%s' cannot be read (%s); rendered magenta" % (img.name, e))
            fname, linear = "__missing__/%s.png" % img.name, False
        j = {"type": "image_texture", "image": fname, "color_space": "linear" if linear else "srgb",
             "interpolation": node.interpolation.lower(), "extension": node.extension.lower(), "inputs": {}}
        vec = _in(node, "Vector")
        if vec is not None and vec.is_linked:
            j["inputs"]["vector"] = self.value(vec, ctx)
        return j


def resolve_bakes(graph, images):
    """A copy of `graph` (a `GraphBuilder.result()`) for one mesh: the baked image names in
    `images` (placeholder -> file) are filled in; references to bakes not in `images` are
    replaced by the reading socket's own value (their "fallback") and their nodes dropped."""
    import copy

    g = copy.deepcopy(graph)
    dropped = set()
    for name, n in list(g["nodes"].items()):
        if n.get("type") == "image_texture" and "/bake:" in name:
            if n["image"] in images:
                n["image"] = images[n["image"]]
            else:
                dropped.add(name)
                del g["nodes"][name]

    def fix(v):
        if isinstance(v, dict):
            if "fallback" in v and "node" in v:
                if v["node"] in dropped:
                    return v["fallback"]
                return {k: x for k, x in v.items() if k != "fallback"}
            return {k: fix(x) for k, x in v.items()}
        if isinstance(v, list):
            return [fix(x) for x in v]
        return v

    for key in g:  # nodes, inputs, closures
        g[key] = fix(g[key])
    return g


def has_bakes(graph):
    return graph is not None and any("/bake:" in k for k in graph.get("nodes", {}))

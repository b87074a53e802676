"""``NAME_blender.py``: a script in every material set that sets the set up in Blender at its
real-world size, with no arithmetic left to the artist.

Run in Blender (``blender --python NAME_blender.py``, or Run Script in its Text Editor), it
reads the maps beside it and makes material ``NAME`` (Principled BSDF; colour sRGB, data maps
Non-Color; the OpenGL normal map through a Normal Map node, a DirectX one with its green
flipped first; a packed map's channels through a Separate Color node; the displacement through
a Displacement node whose Scale is the depth in metres and Midlevel where height 0 lies) and a
plane twice the set's width and height whose UVs run 0..2, so the set tiles 2 x 2 at its real
size. A set in UDIM tiles (:mod:`barkgen.io.udim`) is read as one tiled image a map, on a plane
of the set's size whose UVs run over its tiles.

The plane is displaced once: by default a Displace modifier (strength = the depth in metres,
mid level = the midlevel, the displacement map in UV coordinates) after a simple Subdivision
moves its vertices, so the viewport, EEVEE and Cycles all show the relief, and the material's
own displacement is bump only (``'BUMP'``). With ``-- --displacement shader`` there is no
Displace modifier and Cycles displaces by the material (``'BOTH'``: displacement and bump), as
the material alone does on any subdivided mesh it is given. A UDIM set is always displaced so:
Blender's Displace modifier (and a geometry-nodes image texture) reads a tiled image's first
tile only (Blender 3.4, measured).

The values are the set's ``NAME.json``'s (``width_m``, ``height_m``, ``displacement_depth_m``,
``displacement_midlevel``), written into the script as literals; a set whose real-world size is
unknown is taken as 1 m wide, its depth ``displacement_depth`` (texture widths) metres.
"""

from __future__ import annotations

import json
from collections.abc import Iterable

from barkgen.errors import InvalidInputError
from barkgen.io.udim import UDIM_TOKEN, UdimGrid, udim_file_name
from barkgen.material.presets import MAP_SOURCES, check_preset


def blender_script_name(name: str) -> str:
    """The set's Blender set-up script's file name: ``NAME_blender.py``."""
    return f"{name}_blender.py"


def blender_values(material) -> dict[str, float | str]:
    """The sizes the script sets, as ``NAME.json`` states them: ``width_m``, ``height_m``,
    ``depth_m`` (``displacement_depth_m``), ``midlevel`` (``displacement_midlevel``) and
    ``real_size``; a set of unknown pixel size is 1 m wide, its depth ``displacement_depth``
    (the height range in texture widths) metres."""
    h, w = material.shape
    size = material.physical_size()
    if not size:
        size = {
            "width_m": 1.0,
            "height_m": round(h / w, 6),
            "real_size": "unknown (taken as 1 m wide)",
            "displacement_depth_m": round(material.depth / w, 6),
        }
    return {
        "width_m": float(size["width_m"]),
        "height_m": float(size["height_m"]),
        "depth_m": float(size["displacement_depth_m"]),
        "midlevel": round(material.midlevel, 8),
        "real_size": str(size["real_size"]),
    }


def blender_setup_script(
    material, name: str, files: Iterable[str], preset: str = "ambientcg", *, udim: UdimGrid | None = None
) -> str:
    """The text of ``NAME_blender.py`` for a set (see the module).

    Parameters
    ----------
    material : MaterialSet
        The set (its size in pixels and metres, depth, midlevel, which maps it has).
    name : str
        Its ``NAME``, as :func:`~barkgen.io.material.check_material_name` allows (letters,
        digits, ``_``, ``-``; :func:`~barkgen.io.material.encode_material` checks it).
    files : iterable of str
        The names of the set's image files (``NAME_Color.png`` ...), as ``preset`` writes them.
    preset : {"ambientcg", "blender", "unreal", "unity", "gltf"}, default "ambientcg"
        Their layout (:mod:`barkgen.material.presets`).
    udim : UdimGrid, optional
        The set is written in these UDIM tiles (``files`` are then the whole maps' names, each
        read as ``NAME_Color.<UDIM>.png``).

    Returns
    -------
    str
        Python for Blender (written for 3.x and 4.x, tested with 3.4), its values literals.

    Raises
    ------
    InvalidInputError
        An unknown preset, or a map the layout reads missing from ``files`` (a bug).
    """
    check_preset(preset)
    present = set(files)
    wanted = [key for key in MAP_SOURCES[preset] if key not in ("metalness", "opacity")]
    wanted += [key for key in ("metalness", "opacity") if getattr(material, key) is not None]
    maps = {key: (f"{name}_{MAP_SOURCES[preset][key][0]}.png", MAP_SOURCES[preset][key][1]) for key in wanted}
    missing = sorted({file for file, _ in maps.values()} - present)
    if missing:
        raise InvalidInputError(f"the Blender set-up of {name} reads {', '.join(missing)}, which the set lacks")
    if udim is not None:
        maps = {key: (udim_file_name(file, UDIM_TOKEN), read) for key, (file, read) in maps.items()}
    # an image whose alpha holds data, not the colour's opacity, keeps its channels apart
    packed = sorted({file for key, (file, read) in maps.items() if read in ("A", "1-A") and key != "opacity"})
    values = blender_values(material)
    h, w = material.shape
    q = json.dumps  # (a string as Python reads it, in double quotes: the names are ASCII)
    listing = "".join(f"    {q(key)}: ({q(file)}, {q(read)}),\n" for key, (file, read) in maps.items())
    header = (
        _DOC.replace("NAME", name)
        + "\nimport argparse\nimport math\nimport os\nimport sys\n\nimport bpy\nfrom mathutils import Vector\n\n"
        + f"NAME = {q(name)}\n"
        + f"SCRIPT = {q(blender_script_name(name))}\n"
        + f"#: the set's size in pixels, (width, height)\nSIZE_PX = ({int(w)}, {int(h)})\n"
        + f"#: its real-world size in metres, {values['real_size']}\n"
        + f"WIDTH_M = {values['width_m']!r}\nHEIGHT_M = {values['height_m']!r}\n"
        + "#: highest minus deepest point, metres\n"
        + f"DEPTH_M = {values['depth_m']!r}\n"
        + "#: where height 0 lies in the displacement map, 0..1\n"
        + f"MIDLEVEL = {values['midlevel']!r}\n"
        + f"REAL_SIZE = {q(values['real_size'])}\n"
        + "#: the set's UDIM tiles, [columns, rows] (each map one tiled image); None: one image a map\n"
        + f"UDIM = {None if udim is None else [udim.columns, udim.rows]!r}\n"
        + "#: map -> (file beside this script, how its value is read: RGB colour, V grey value,\n"
        + "#: R/G/B/A one channel, 1-A one minus alpha; the normal map's convention)\n"
        + "MAPS = {\n"
        + listing
        + "}\n"
        + "#: images whose channels are separate data (their alpha is no opacity)\n"
        + f"CHANNEL_PACKED = [{', '.join(map(q, packed))}]\n"
    )
    return header + _BODY


_DOC = '''"""Set up the material set NAME in Blender at its real-world size.

Made by barkgen, the sizes below NAME.json's. Run

    blender --python NAME_blender.py [-- --save NAME.blend] [--render NAME.png]

or open this file in Blender's Text Editor and press Run Script. The maps are read from the
folder this file is in (keep it beside them). It makes

- material NAME: Principled BSDF; colour sRGB, the data maps Non-Color; the normal map through
  a Normal Map node (a DirectX one with its green flipped first); packed maps through a
  Separate Color node; the displacement map through a Displacement node (Scale = DEPTH_M, the
  depth in metres; Midlevel = MIDLEVEL) into the Material Output's Displacement;
- object NAME: a plane 2 x WIDTH_M by 2 x HEIGHT_M metres whose UVs run 0..2 (the set 2 x 2
  at its real size), with a Subdivision modifier (simple) and a Displace modifier driven by the
  displacement map in UV coordinates (Strength = DEPTH_M, Midlevel = MIDLEVEL). A set in UDIM
  tiles: a plane WIDTH_M by HEIGHT_M whose UVs run over its tiles, each map one tiled image.

The plane is displaced once: by the Displace modifier (the viewport, EEVEE and Cycles all show
it), the material's own displacement left at Bump Only. With `--displacement shader` there is
no Displace modifier and Cycles displaces by the material (Displacement and Bump), as the
material alone does on any subdivided mesh you give it. A UDIM set is always displaced by the
material: the Displace modifier reads one tile of a tiled image (and without bump: Cycles' bump
draws a line along each tile border; the normal map carries the fine relief).

Options after `--`: --save PATH.blend (save the file), --render PATH.png (a Cycles render;
--resolution PX, --samples N, --focus U,V: aimed at that UV point, one tile in view),
--displacement {modifier,shader}.
"""
'''

# the script's code, plain Python for Blender 3.x and 4.x (Python 3.7 and later; tested with 3.4); a plain
# string, not an f-string: its braces are the script's own
_BODY = '''UV_MAP = "UVMap"
#: times the set repeats along each side of the plane (a UDIM set: once, its UVs over its tiles)
REPEAT = 2 if UDIM is None else 1
#: the UV square the plane spans, (u, v)
UV_RANGE = (REPEAT, REPEAT) if UDIM is None else tuple(UDIM)
#: the plane's grid: cells along its longer side, then a simple Subdivision to about a vertex a
#: pixel, at most this many segments along the longer side in the viewport and in renders
CELLS = 8
VIEWPORT_SEGMENTS = 512
RENDER_SEGMENTS = 1024


def set_folder():
    """The folder of this script, where the maps are: ``__file__``'s under --python, the
    text's own file in Blender's Text Editor."""
    candidates = []
    if "__file__" in globals():
        candidates.append(os.path.dirname(os.path.abspath(__file__)))
    texts = [getattr(getattr(bpy.context, "space_data", None), "text", None)]
    texts += [t for t in bpy.data.texts if SCRIPT in (t.name, os.path.basename(t.filepath))]
    candidates += [os.path.dirname(bpy.path.abspath(t.filepath)) for t in texts if t is not None and t.filepath]
    for folder in candidates:
        if os.path.isfile(os.path.join(folder, first_tile(MAPS["displacement"][0]))):
            return folder
    raise RuntimeError(
        f"{SCRIPT}: {first_tile(MAPS['displacement'][0])} is not beside this script; keep the script in the set's "
        f"folder and run it from there (blender --python {SCRIPT}, or open it in the Text Editor and Run Script)"
    )


def first_tile(file):
    """The file of a map's first UDIM tile (1001), or the map's own file."""
    return file.replace("<UDIM>", "1001")


def node_kind(new, old):
    """A node type by its current name, or its name before Blender 3.3."""
    return new if hasattr(bpy.types, new) else old


class Nodes:
    """The material's node tree, built left to right."""

    def __init__(self, material, folder):
        self.tree = material.node_tree
        self.folder = folder
        self.images = {}
        self.separated = {}

    def new(self, kind, x, y):
        node = self.tree.nodes.new(kind)
        node.location = (x, y)
        return node

    def link(self, socket, to):
        self.tree.links.new(socket, to)

    def image(self, file):
        """The Image Texture node of a map: sRGB for the colour, else Non-Color."""
        if file not in self.images:
            node = self.new("ShaderNodeTexImage", -1000, 400 - 300 * len(self.images))
            node.image = bpy.data.images.load(os.path.join(self.folder, first_tile(file)), check_existing=True)
            if UDIM is not None:  # finds the other tiles beside it: NAME_Color.<UDIM>.png
                node.image.source = "TILED"
            node.image.colorspace_settings.name = "sRGB" if file == MAPS["color"][0] else "Non-Color"
            if file in CHANNEL_PACKED:
                node.image.alpha_mode = "CHANNEL_PACKED"
            node.label = file
            self.images[file] = node
        return self.images[file]

    def separate(self, file):
        """A Separate Color (RGB) node on a map's colour."""
        if file not in self.separated:
            image = self.image(file)
            node = self.new(node_kind("ShaderNodeSeparateColor", "ShaderNodeSeparateRGB"), -700, image.location.y)
            self.link(image.outputs["Color"], node.inputs[0])
            self.separated[file] = node
        return self.separated[file]

    def one_minus(self, socket, x, y):
        node = self.new("ShaderNodeMath", x, y)
        node.operation = "SUBTRACT"
        node.inputs[0].default_value = 1.0
        self.link(socket, node.inputs[1])
        return node.outputs[0]

    def value(self, key):
        """The socket that gives map ``key``'s value, as MAPS says it is read."""
        file, read = MAPS[key]
        image = self.image(file)
        if read in ("RGB", "V"):
            return image.outputs["Color"]
        if read == "A":
            return image.outputs["Alpha"]
        if read == "1-A":
            return self.one_minus(image.outputs["Alpha"], -500, image.location.y)
        return self.separate(file).outputs["RGB".index(read)]

    def normal(self):
        """The tangent-space normal map's colour, OpenGL's convention (green up)."""
        file, convention = MAPS["normal"]
        if convention == "OpenGL":
            return self.image(file).outputs["Color"]
        parts = self.separate(file)  # DirectX: green down, flipped
        y = parts.location.y
        combine = self.new(node_kind("ShaderNodeCombineColor", "ShaderNodeCombineRGB"), -300, y)
        self.link(parts.outputs[0], combine.inputs[0])
        self.link(self.one_minus(parts.outputs[1], -500, y), combine.inputs[1])
        self.link(parts.outputs[2], combine.inputs[2])
        return combine.outputs[0]


def set_displacement_method(material, method):
    """The material's displacement method (a Cycles setting before Blender 4.1)."""
    owner = material if hasattr(material, "displacement_method") else material.cycles
    owner.displacement_method = method


def build_material(folder, displacement):
    """Material NAME wired from the maps in ``folder``; its displacement method as
    ``displacement`` says (``modifier``: bump only, the Displace modifier moves the plane)."""
    material = bpy.data.materials.new(NAME)
    material.use_nodes = True
    material.node_tree.nodes.clear()
    nodes = Nodes(material, folder)
    output = nodes.new("ShaderNodeOutputMaterial", 400, 0)
    bsdf = nodes.new("ShaderNodeBsdfPrincipled", 0, 200)
    nodes.link(bsdf.outputs["BSDF"], output.inputs["Surface"])
    nodes.link(nodes.value("color"), bsdf.inputs["Base Color"])
    nodes.link(nodes.value("roughness"), bsdf.inputs["Roughness"])
    if "metalness" in MAPS:
        nodes.link(nodes.value("metalness"), bsdf.inputs["Metallic"])
    if "opacity" in MAPS:
        nodes.link(nodes.value("opacity"), bsdf.inputs["Alpha"])
        if hasattr(material, "blend_method"):  # EEVEE before 4.2
            material.blend_method = "HASHED"
    normal_map = nodes.new("ShaderNodeNormalMap", -200, -300)
    normal_map.space = "TANGENT"
    normal_map.uv_map = UV_MAP
    nodes.link(nodes.normal(), normal_map.inputs["Color"])
    nodes.link(normal_map.outputs["Normal"], bsdf.inputs["Normal"])
    node = nodes.new("ShaderNodeDisplacement", 100, -450)
    node.space = "OBJECT"
    node.inputs["Scale"].default_value = DEPTH_M
    node.inputs["Midlevel"].default_value = MIDLEVEL
    nodes.link(nodes.value("displacement"), node.inputs["Height"])
    nodes.link(node.outputs["Displacement"], output.inputs["Displacement"])
    # a UDIM set's height bumps no more: Cycles' bump reads a step across a tile border (a dark
    # line along it, measured in Blender 3.4); its normal map carries the fine relief
    set_displacement_method(material, "BUMP" if displacement == "modifier" else "BOTH" if UDIM is None else "DISPLACEMENT")
    return material, nodes.image(MAPS["displacement"][0]).image


def subdivision_level(segments):
    """Simple subdivisions of the base grid to about a vertex a pixel of the set REPEAT x
    REPEAT, at most ``segments`` along the longer side."""
    level = 0
    while CELLS * 2**level < min(REPEAT * max(SIZE_PX), segments):
        level += 1
    return level


def plane_mesh(material):
    """A plane REPEAT x WIDTH_M by REPEAT x HEIGHT_M metres, centred, its UVs over UV_RANGE,
    smooth, a grid of about square cells (CELLS along its longer side)."""
    width, height = SIZE_PX
    nx = CELLS if width >= height else max(1, round(CELLS * width / height))
    ny = CELLS if height >= width else max(1, round(CELLS * height / width))
    corners = [(i, j) for j in range(ny + 1) for i in range(nx + 1)]
    vertices = [((i / nx - 0.5) * REPEAT * WIDTH_M, (j / ny - 0.5) * REPEAT * HEIGHT_M, 0.0) for i, j in corners]
    row = nx + 1
    faces = [
        (j * row + i, j * row + i + 1, (j + 1) * row + i + 1, (j + 1) * row + i) for j in range(ny) for i in range(nx)
    ]
    mesh = bpy.data.meshes.new(NAME)
    mesh.from_pydata(vertices, [], faces)
    uv = mesh.uv_layers.new(name=UV_MAP)
    for loop in mesh.loops:
        i, j = corners[loop.vertex_index]
        uv.data[loop.index].uv = (UV_RANGE[0] * i / nx, UV_RANGE[1] * j / ny)
    for polygon in mesh.polygons:
        polygon.use_smooth = True
    mesh.materials.append(material)
    mesh.update()
    return mesh


def build_plane(material, image, displacement):
    """Object NAME: the plane at the 3D cursor, subdivided, and displaced by a Displace modifier
    unless ``displacement`` is ``shader``."""
    obj = bpy.data.objects.new(NAME, plane_mesh(material))
    obj.location = bpy.context.scene.cursor.location
    collection = getattr(bpy.context, "collection", None) or bpy.context.scene.collection
    collection.objects.link(obj)
    subdivision = obj.modifiers.new("Subdivision", "SUBSURF")
    subdivision.subdivision_type = "SIMPLE"
    subdivision.levels = subdivision_level(VIEWPORT_SEGMENTS)
    subdivision.render_levels = subdivision_level(RENDER_SEGMENTS)
    if displacement == "modifier":
        texture = bpy.data.textures.new(NAME + "_Displacement", type="IMAGE")
        texture.image = image
        texture.extension = "REPEAT"
        displace = obj.modifiers.new("Displace", "DISPLACE")
        displace.texture = texture
        displace.texture_coords = "UV"
        displace.uv_layer = UV_MAP
        displace.direction = "NORMAL"
        displace.strength = DEPTH_M
        displace.mid_level = MIDLEVEL
    return obj


def render(obj, path, resolution, samples, focus=None):
    """A Cycles render of the plane alone, seen from 50 degrees up under a low sun, to ``path``
    (a scene of its own, removed afterwards): the whole plane, or aimed at UV point ``focus``
    with one tile (one set) in view."""
    scene = bpy.data.scenes.new(NAME + "_render")
    scene.collection.objects.link(obj)
    span = REPEAT * max(WIDTH_M, HEIGHT_M)
    target = obj.location.copy()
    if focus is not None:
        u, v = focus
        target += Vector(((u / UV_RANGE[0] - 0.5) * REPEAT * WIDTH_M, (v / UV_RANGE[1] - 0.5) * REPEAT * HEIGHT_M, 0))
        span = max(REPEAT * WIDTH_M / UV_RANGE[0], REPEAT * HEIGHT_M / UV_RANGE[1])
    camera = bpy.data.objects.new(NAME + "_camera", bpy.data.cameras.new(NAME + "_camera"))
    elevation = math.radians(50)
    camera.location = target + Vector((0, -math.cos(elevation), math.sin(elevation))) * 1.6 * span
    camera.rotation_euler = (target - camera.location).to_track_quat("-Z", "Y").to_euler()
    sun = bpy.data.objects.new(NAME + "_sun", bpy.data.lights.new(NAME + "_sun", "SUN"))
    sun.data.energy = 4.0
    sun.rotation_euler = (math.radians(65), 0.0, math.radians(40))
    world = bpy.data.worlds.new(NAME + "_render")
    world.color = (0.05, 0.05, 0.05)
    for extra in (camera, sun):
        scene.collection.objects.link(extra)
    scene.camera, scene.world = camera, world
    scene.render.engine = "CYCLES"
    scene.cycles.device = "CPU"
    scene.cycles.samples = samples
    scene.cycles.use_denoising = False
    scene.render.resolution_x = scene.render.resolution_y = resolution
    scene.render.resolution_percentage = 100
    scene.render.image_settings.file_format = "PNG"
    scene.render.image_settings.color_mode = "RGB"
    scene.render.filepath = os.path.abspath(path)
    try:
        bpy.ops.render.render(write_still=True, scene=scene.name)
    finally:
        for extra in (camera, sun):
            data = extra.data
            bpy.data.objects.remove(extra)
            (bpy.data.cameras if extra is camera else bpy.data.lights).remove(data)
        bpy.data.scenes.remove(scene)
        bpy.data.worlds.remove(world)


def arguments(argv):
    parser = argparse.ArgumentParser(prog="blender --python " + SCRIPT + " --", description=__doc__.splitlines()[0])
    parser.add_argument("--save", metavar="PATH.blend", help="save the file there")
    parser.add_argument("--render", metavar="PATH.png", help="render the plane there (Cycles)")
    parser.add_argument("--resolution", type=int, default=512, metavar="PX", help="the render's width and height")
    parser.add_argument("--samples", type=int, default=32, metavar="N", help="the render's samples a pixel")
    parser.add_argument("--focus", metavar="U,V", help="aim the render at this UV point, one tile in view")
    parser.add_argument(
        "--displacement",
        choices=("modifier", "shader"),
        default="modifier" if UDIM is None else "shader",
        help="modifier: a Displace modifier moves the plane (viewport, EEVEE, Cycles), the material bumps only; "
        "shader: Cycles displaces by the material (a UDIM set's only way: the modifier reads one tile)",
    )
    args = parser.parse_args(argv)
    if args.resolution < 1 or args.samples < 1:
        parser.error("--resolution and --samples must be at least 1")
    if UDIM is not None and args.displacement == "modifier":
        parser.error(
            "a UDIM set is displaced by the material (--displacement shader): Blender's Displace modifier "
            "reads one tile of a tiled image"
        )
    if args.focus is not None:
        try:
            args.focus = tuple(float(x) for x in args.focus.split(","))
        except ValueError:
            args.focus = ()
        if len(args.focus) != 2:
            parser.error("--focus takes a UV point U,V (e.g. 1,0.5)")
    return args


def main(argv):
    args = arguments(argv)
    folder = set_folder()
    material, image = build_material(folder, args.displacement)
    obj = build_plane(material, image, args.displacement)
    if getattr(bpy.context, "view_layer", None) is not None and obj.name in bpy.context.view_layer.objects:
        bpy.context.view_layer.objects.active = obj
    done = []
    if args.render:
        render(obj, args.render, args.resolution, args.samples, args.focus)
        done.append("rendered " + args.render)
    if args.save:
        bpy.ops.wm.save_as_mainfile(filepath=os.path.abspath(args.save))
        done.append("saved " + args.save)
    how = "its Displace modifier" if args.displacement == "modifier" else "the material (Cycles)"
    size = f"{2 * WIDTH_M:g} x {2 * HEIGHT_M:g} m: the set 2 x 2 at {WIDTH_M:g} x {HEIGHT_M:g} m ({REAL_SIZE})"
    if UDIM is not None:
        size = f"{WIDTH_M:g} x {HEIGHT_M:g} m: the set's {UDIM[0]} x {UDIM[1]} UDIM tiles ({REAL_SIZE})"
    relief = f"its relief {1000 * DEPTH_M:.4g} mm deep (midlevel {MIDLEVEL:.4g}) displaced by {how}"
    made = f"{SCRIPT}: material {material.name} and plane {obj.name}, {size}, {relief}, from {folder}"
    print(made + "".join("; " + d for d in done))


main(sys.argv[sys.argv.index("--") + 1 :] if "--" in sys.argv else [])
'''

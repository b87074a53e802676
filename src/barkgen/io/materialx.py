"""A material set as a MaterialX document (``NAME.mtlx``, the Blender preset; PyPI
``materialx``, the ``[materialx]`` extra).

One ``standard_surface`` fed by a node graph of the set's images — the colour in sRGB, the data
maps raw, the OpenGL normal map through a ``normalmap`` node — and a ``displacement`` shader
whose input is the displacement re-centred on its midlevel and whose scale is the depth in
metres (``displacement_depth_m`` of ``NAME.json``) on a surface as wide as the set's real-world
width (``width_m``), so a renderer displaces by as much as the set's normals slope.
"""

from __future__ import annotations

from barkgen.errors import InvalidInputError


def _materialx():
    from barkgen._shared.extras import require_extra

    require_extra("materialx", "the Blender preset's MaterialX document")
    import MaterialX as mx

    return mx


def build_mtlx(name: str, files: dict[str, str], *, depth: float, midlevel: float):
    """The MaterialX document (a ``MaterialX.Document``) of a set whose maps are the files
    ``files`` (``color``, ``normal``, ``roughness``, ``displacement``, optional ``metalness``
    and ``opacity`` -> file name), displacement ``depth`` in the surface's units (metres on a
    surface as wide as the set's ``width_m``), ``midlevel`` in [0, 1]."""
    mx = _materialx()
    doc = mx.createDocument()
    graph = doc.addNodeGraph(f"NG_{name}")

    def image(key: str, kind: str, srgb: bool = False):
        node = graph.addNode("image", f"{key}_image", kind)
        file_input = node.setInputValue("file", files[key], "filename")
        if srgb:
            file_input.setColorSpace("srgb_texture")
        return node

    outputs = {}
    color = image("color", "color3", srgb=True)
    outputs["base_color"] = graph.addOutput("base_color_output", "color3")
    outputs["base_color"].setConnectedNode(color)
    normal = graph.addNode("normalmap", "normal_map", "vector3")
    normal.setConnectedNode("in", image("normal", "vector3"))
    outputs["normal"] = graph.addOutput("normal_output", "vector3")
    outputs["normal"].setConnectedNode(normal)
    for key, port in (("roughness", "specular_roughness"), ("metalness", "metalness"), ("opacity", "opacity")):
        if key in files:
            kind = "color3" if port == "opacity" else "float"
            node = image(key, kind)
            outputs[port] = graph.addOutput(f"{key}_output", kind)
            outputs[port].setConnectedNode(node)
    centred = graph.addNode("subtract", "displacement_centred", "float")
    centred.setConnectedNode("in1", image("displacement", "float"))
    centred.setInputValue("in2", float(midlevel), "float")
    outputs["displacement"] = graph.addOutput("displacement_output", "float")
    outputs["displacement"].setConnectedNode(centred)

    surface = doc.addNode("standard_surface", f"SR_{name}", "surfaceshader")
    surface.setInputValue("base", 1.0, "float")
    surface.setInputValue("specular", 0.5, "float")
    for port, output in outputs.items():
        if port == "displacement":
            continue
        kind = {"base_color": "color3", "normal": "vector3", "opacity": "color3"}.get(port, "float")
        surface_input = surface.addInput(port, kind)
        surface_input.setNodeGraphString(graph.getName())
        surface_input.setOutputString(output.getName())
    displacement = doc.addNode("displacement", f"DS_{name}", "displacementshader")
    disp_input = displacement.addInput("displacement", "float")
    disp_input.setNodeGraphString(graph.getName())
    disp_input.setOutputString(outputs["displacement"].getName())
    displacement.setInputValue("scale", float(depth), "float")
    material = doc.addMaterialNode(f"M_{name}", surface)
    material.addInput("displacementshader", "displacementshader").setConnectedNode(displacement)
    return doc


def validate_mtlx(text: str) -> tuple[bool, str]:
    """MaterialX's own ``validate`` of a document's text, against its standard libraries:
    ``(valid, messages)``."""
    mx = _materialx()
    doc = mx.createDocument()
    mx.readFromXmlString(doc, text)
    libraries = mx.createDocument()
    mx.loadLibraries(mx.getDefaultDataLibraryFolders(), mx.getDefaultDataSearchPath(), libraries)
    doc.setDataLibrary(libraries)
    valid, messages = doc.validate()
    return bool(valid), str(messages)


def encode_mtlx(name: str, files: dict[str, str], *, depth: float, midlevel: float) -> bytes:
    """``NAME.mtlx`` (see :func:`build_mtlx`), checked by MaterialX's ``validate`` before it is
    returned.

    Raises
    ------
    MissingExtraError
        ``materialx`` is not installed (``pip install 'barkgen[materialx]'``).
    InvalidInputError
        The document does not validate (a bug: it names the message).
    """
    mx = _materialx()
    text = mx.writeToXmlString(build_mtlx(name, files, depth=depth, midlevel=midlevel))
    valid, messages = validate_mtlx(text)
    if not valid:
        raise InvalidInputError(f"{name}.mtlx does not validate: {messages.strip()}")
    return text.encode()

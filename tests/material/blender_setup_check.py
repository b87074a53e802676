"""Run inside Blender after a set's ``NAME_blender.py`` (``blender -b --factory-startup --python
NAME_blender.py --python THIS``): one JSON line per plane that script made (an object with a
Subdivision modifier and a material of its own name), saying what the set-up holds: the
Displacement node's scale and midlevel and what feeds it, the material's displacement method,
the plane's size and UV range, its evaluated vertex heights, the modifiers' settings, the
images' colour spaces and the chain of nodes behind each Principled input."""

import json

import bpy


def upstream(tree, node, socket_name):
    """The nodes behind one input of ``node``, nearest first: ``[type or image name, ...]``."""
    chain = []
    link = next((l for l in tree.links if l.to_node == node and l.to_socket.name == socket_name), None)
    while link is not None:
        source = link.from_node
        if source.type == "TEX_IMAGE":
            chain.append(f"{source.image.name}:{link.from_socket.name}")
            break
        chain.append(f"{source.type}:{link.from_socket.name}")
        # on through the first linked input; a Math node's second (its first is the constant 1)
        # and a Combine node's green (the one a DirectX normal map has flipped)
        inputs = [s for s in source.inputs if s.is_linked]
        if source.type in ("MATH", "COMBINE_COLOR", "COMBINE_RGB"):
            inputs = [source.inputs[1]]
        link = next((l for l in tree.links if inputs and l.to_socket == inputs[0]), None)
    return chain


def report(obj):
    material = obj.material_slots[0].material
    tree = material.node_tree
    principled = next(n for n in tree.nodes if n.type == "BSDF_PRINCIPLED")
    output = next(n for n in tree.nodes if n.type == "OUTPUT_MATERIAL")
    displacement = next(n for n in tree.nodes if n.type == "DISPLACEMENT")
    method = getattr(material, "displacement_method", None) or material.cycles.displacement_method
    mesh = obj.data
    xs = [v.co.x for v in mesh.vertices]
    ys = [v.co.y for v in mesh.vertices]
    uvs = [d.uv[:] for d in mesh.uv_layers[0].data]
    evaluated = obj.evaluated_get(bpy.context.evaluated_depsgraph_get())
    heights = [v.co.z for v in evaluated.to_mesh().vertices]
    evaluated.to_mesh_clear()
    modifiers = {}
    for m in obj.modifiers:
        if m.type == "DISPLACE":
            modifiers[m.type] = {
                "strength": m.strength,
                "mid_level": m.mid_level,
                "texture_coords": m.texture_coords,
                "image": m.texture.image.name,
            }
        else:
            modifiers[m.type] = {"subdivision_type": m.subdivision_type, "levels": m.levels}
    return {
        "material": material.name,
        "object": obj.name,
        "displacement": {
            "scale": displacement.inputs["Scale"].default_value,
            "midlevel": displacement.inputs["Midlevel"].default_value,
            "height": upstream(tree, displacement, "Height"),
            "to_output": upstream(tree, output, "Displacement")[:1],
            "method": method,
        },
        "plane": {"width": max(xs) - min(xs), "height": max(ys) - min(ys)},
        "uv": [min(u for u, _ in uvs), max(u for u, _ in uvs), min(v for _, v in uvs), max(v for _, v in uvs)],
        "heights": {"min": min(heights), "max": max(heights), "mean": sum(heights) / len(heights), "n": len(heights)},
        "modifiers": modifiers,
        "alpha_modes": {n.image.name: n.image.alpha_mode for n in tree.nodes if n.type == "TEX_IMAGE"},
        "colour_spaces": {n.image.name: n.image.colorspace_settings.name for n in tree.nodes if n.type == "TEX_IMAGE"},
        "tiles": {
            n.image.name: [t.number for t in n.image.tiles] if n.image.source == "TILED" else None
            for n in tree.nodes
            if n.type == "TEX_IMAGE"
        },
        "wired": {
            name: upstream(tree, principled, name)
            for name in ("Base Color", "Normal", "Roughness", "Metallic", "Alpha")
        },
    }


for obj in bpy.data.objects:
    slots = getattr(obj, "material_slots", [])
    if any(m.type == "SUBSURF" for m in obj.modifiers) and slots and slots[0].material.name == obj.name:
        print("BARKGEN-JSON" + json.dumps(report(obj)))

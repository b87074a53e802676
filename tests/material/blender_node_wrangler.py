"""Run inside Blender (``blender -b --factory-startup --python THIS -- FOLDER``): Node Wrangler's
"Add Principled Setup" on every PNG of FOLDER, as an artist's click runs it (its own operator's
execute, given the folder's files and a material whose Principled BSDF is active; Blender in
the background has no node editor to click in), then one JSON line: the image each Principled
input is wired from, and every image's colour space."""

import json
import os
import sys
import types

import addon_utils
import bpy

addon_utils.enable("node_wrangler", default_set=True)
import node_wrangler  # noqa: E402  (importable once enabled)

folder = sys.argv[sys.argv.index("--") + 1]
material = bpy.data.materials.new("bark")
material.use_nodes = True
tree = material.node_tree
principled = tree.nodes.get("Principled BSDF")
tree.nodes.active = principled
operator = types.SimpleNamespace(
    directory=folder + os.sep,
    files=[types.SimpleNamespace(name=name) for name in sorted(os.listdir(folder)) if name.endswith(".png")],
    relative_path=False,
    report=lambda level, message: print("node wrangler:", level, message),
)
space = types.SimpleNamespace(node_tree=tree, edit_tree=tree, type="NODE_EDITOR", tree_type="ShaderNodeTree")
context = types.SimpleNamespace(
    space_data=space, preferences=bpy.context.preferences, active_node=principled, scene=bpy.context.scene
)
finished = node_wrangler.NWAddPrincipledSetup.execute(operator, context)


def wired_from(socket_name):
    """The image behind a Principled input (through a Normal Map or other node), or None."""
    for link in tree.links:
        if link.to_node == principled and link.to_socket.name == socket_name:
            node = link.from_node
            while node.type != "TEX_IMAGE":
                inputs = [l for l in tree.links if l.to_node == node]
                if not inputs:
                    return None
                node = inputs[0].from_node
            return node.image.name
    return None


report = {
    "finished": "FINISHED" in finished,
    "wired": {name: wired_from(name) for name in ("Base Color", "Normal", "Roughness", "Metallic", "Alpha")},
    "normal_map_node": any(n.type == "NORMAL_MAP" for n in tree.nodes),
    "colour_spaces": {n.image.name: n.image.colorspace_settings.name for n in tree.nodes if n.type == "TEX_IMAGE"},
}
print("BARKGEN-JSON" + json.dumps(report))

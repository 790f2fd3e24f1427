"""Build the small Blender room and export it to scenes/room.glb with Blender's glTF exporter.

Runs Blender as the Python module `bpy` (pip install bpy; 5.0.1 for Python 3.11):

    python3 scenes/blender/room.py [--out scenes/room.glb] [--cycles cycles.exr --width 128]

The room (Blender axes, Z up; the exporter turns them into glTF's +Y up):
- a 4 m x 4 m floor, a back wall and a left wall, grey diffuse (Principled, roughness 1);
- a ceiling strip of 8 emissive quads made by an Array modifier (applied at export), two-sided;
- a mirrored linked duplicate of that strip (scale x = -1: a negative-determinant node);
- a one-sided emitter (Backface Culling on) and a two-sided one (off) on the right;
- a textured emitter on the back wall: a 16 x 16 image made here, read through a Mapping node
  (exported as KHR_texture_transform);
- a camera, and a 100 W point light, a 300 W spot light and a 2 W/m^2 sun in the default
  (Standard) lighting mode, which writes W/(4 pi) * 683 cd and W/m^2 * 683 lx.

--cycles renders the same view with Cycles on the CPU, direct light only (0 bounces), box filter
0.01 px, to an OpenEXR file for comparison.
"""

import argparse
import math
import os
import sys

import bpy

POINT_W = 100.0
SPOT_W = 300.0
SUN_W_M2 = 2.0
STRIP_STRENGTH = 5.0
SIDED_STRENGTH = 3.0
TEXTURE_STRENGTH = 4.0


def material(name, colour, emission=None, strength=0.0, culling=False):
    mat = bpy.data.materials.new(name)
    bsdf = mat.node_tree.nodes["Principled BSDF"]
    bsdf.inputs["Base Color"].default_value = (*colour, 1.0)
    bsdf.inputs["Roughness"].default_value = 1.0
    if emission is not None:
        bsdf.inputs["Emission Color"].default_value = (*emission, 1.0)
        bsdf.inputs["Emission Strength"].default_value = strength
    mat.use_backface_culling = culling
    return mat


def quad(name, size_x, size_y, location, rotation, mat):
    bpy.ops.mesh.primitive_plane_add(size=1.0, location=location, rotation=rotation)
    obj = bpy.context.active_object
    obj.name = name
    obj.scale = (size_x, size_y, 1.0)
    bpy.ops.object.transform_apply(location=False, rotation=False, scale=True)
    obj.data.materials.append(mat)
    return obj


def texture_material():
    size = 16
    image = bpy.data.images.new("room_stripes", size, size)
    pixels = []
    for y in range(size):
        for x in range(size):
            on = (x // 4 + y // 4) % 2 == 0
            pixels += [1.0, 0.8, 0.5, 1.0] if on else [0.05, 0.1, 0.3, 1.0]
    image.pixels = pixels
    image.pack()
    mat = material("textured_emitter", (0.0, 0.0, 0.0), (1.0, 1.0, 1.0), TEXTURE_STRENGTH)
    nodes = mat.node_tree.nodes
    links = mat.node_tree.links
    coords = nodes.new("ShaderNodeTexCoord")
    mapping = nodes.new("ShaderNodeMapping")
    mapping.inputs["Scale"].default_value = (2.0, 2.0, 1.0)
    mapping.inputs["Location"].default_value = (0.25, 0.0, 0.0)
    tex = nodes.new("ShaderNodeTexImage")
    tex.image = image
    tex.interpolation = "Closest"
    links.new(coords.outputs["UV"], mapping.inputs["Vector"])
    links.new(mapping.outputs["Vector"], tex.inputs["Vector"])
    links.new(tex.outputs["Color"], nodes["Principled BSDF"].inputs["Emission Color"])
    return mat


def build():
    bpy.ops.wm.read_factory_settings(use_empty=True)
    grey = material("wall", (0.6, 0.6, 0.6))
    quad("floor", 4.0, 4.0, (0, 0, 0), (0, 0, 0), grey)
    quad("back_wall", 4.0, 3.0, (0, 2.0, 1.5), (math.pi / 2, 0, 0), grey)
    quad("left_wall", 4.0, 3.0, (-2.0, 0, 1.5), (math.pi / 2, 0, math.pi / 2), grey)

    strip_mat = material("strip", (0, 0, 0), (1.0, 0.9, 0.7), STRIP_STRENGTH)
    strip = quad("strip", 0.2, 0.1, (0.5, -1.2, 2.8), (math.pi, 0, 0), strip_mat)
    array = strip.modifiers.new("array", "ARRAY")
    array.count = 8
    array.relative_offset_displace = (0.0, 2.0, 0.0)
    mirrored = strip.copy()  # linked duplicate: shares the mesh data
    mirrored.name = "strip_mirrored"
    mirrored.location = (-0.5, -1.2, 2.8)
    mirrored.scale = (-1.0, 1.0, 1.0)
    bpy.context.collection.objects.link(mirrored)

    one = material("one_sided", (0, 0, 0), (0.3, 0.6, 1.0), SIDED_STRENGTH, culling=True)
    two = material("two_sided", (0, 0, 0), (1.0, 0.4, 0.3), SIDED_STRENGTH, culling=False)
    quad("one_sided", 0.4, 0.4, (1.6, 0.6, 1.0), (0, math.pi / 2, 0), one)
    quad("two_sided", 0.4, 0.4, (1.6, -0.6, 1.0), (0, math.pi / 2, 0), two)
    quad("textured", 1.0, 0.6, (0.2, 1.99, 1.6), (math.pi / 2, 0, 0), texture_material())

    point = bpy.data.lights.new("point", "POINT")
    point.energy = POINT_W
    point.shadow_soft_size = 0.0
    obj = bpy.data.objects.new("point", point)
    obj.location = (-1.0, 0.5, 2.0)
    bpy.context.collection.objects.link(obj)

    spot = bpy.data.lights.new("spot", "SPOT")
    spot.energy = SPOT_W
    spot.shadow_soft_size = 0.0
    spot.spot_size = math.radians(60.0)
    spot.spot_blend = 0.2
    obj = bpy.data.objects.new("spot", spot)
    obj.location = (0.8, -0.5, 2.7)
    obj.rotation_euler = (math.radians(15), 0, 0)
    bpy.context.collection.objects.link(obj)

    sun = bpy.data.lights.new("sun", "SUN")
    sun.energy = SUN_W_M2
    sun.angle = 0.0
    obj = bpy.data.objects.new("sun", sun)
    obj.rotation_euler = (math.radians(40), 0, math.radians(30))
    bpy.context.collection.objects.link(obj)

    cam = bpy.data.cameras.new("camera")
    cam.lens = 24.0
    obj = bpy.data.objects.new("camera", cam)
    obj.location = (0.6, -4.5, 1.6)
    obj.rotation_euler = (math.radians(86), 0, math.radians(4))
    bpy.context.collection.objects.link(obj)
    bpy.context.scene.camera = obj
    # The exporter writes the camera's aspect ratio from the render resolution: 4:3.
    bpy.context.scene.render.resolution_x = 640
    bpy.context.scene.render.resolution_y = 480


def export(path):
    bpy.ops.export_scene.gltf(
        filepath=path,
        export_format="GLB",
        export_cameras=True,
        export_lights=True,
        export_apply=True,
        export_import_convert_lighting_mode="SPEC",
    )


def render_cycles(path, width):
    scene = bpy.context.scene
    scene.render.engine = "CYCLES"
    scene.cycles.device = "CPU"
    scene.cycles.samples = 256
    scene.cycles.use_denoising = False
    scene.cycles.max_bounces = 0
    scene.cycles.diffuse_bounces = 0
    scene.cycles.glossy_bounces = 0
    scene.cycles.transmission_bounces = 0
    scene.cycles.pixel_filter_type = "BOX"
    scene.cycles.filter_width = 0.01
    scene.cycles.seed = 1
    # No world light: a new world's Background node emits a 0.05 grey unless turned off.
    scene.world = bpy.data.worlds.new("black")
    scene.world.color = (0.0, 0.0, 0.0)
    if scene.world.node_tree is not None:
        for node in scene.world.node_tree.nodes:
            if node.type == "BACKGROUND":
                node.inputs["Strength"].default_value = 0.0
    scene.view_settings.view_transform = "Standard"
    scene.render.resolution_x = width
    scene.render.resolution_y = width * 3 // 4
    scene.render.resolution_percentage = 100
    scene.render.image_settings.file_format = "OPEN_EXR"
    scene.render.image_settings.color_depth = "32"
    scene.render.filepath = path
    bpy.ops.render.render(write_still=True)


def main():
    here = os.path.dirname(os.path.abspath(__file__))
    parser = argparse.ArgumentParser()
    parser.add_argument("--out", default=os.path.join(here, "..", "room.glb"))
    parser.add_argument("--cycles", help="also render with Cycles to this EXR")
    parser.add_argument("--width", type=int, default=128)
    args = parser.parse_args(sys.argv[1:])
    build()
    export(os.path.abspath(args.out))
    if args.cycles:
        render_cycles(os.path.abspath(args.cycles), args.width)


if __name__ == "__main__":
    main()

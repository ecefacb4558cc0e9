#!/usr/bin/env python3
"""Writes the scenes shipped in scenes/ (COLLADA, CS184 dialect, Y_UP).

Run from the repository root: python3 scenes/generate.py
The .dae files are committed; this script documents how they were made.
"""
import math
import os

HERE = os.path.dirname(os.path.abspath(__file__))


def fmt(xs):
    return " ".join(f"{x:.6g}" for x in xs)


class Scene:
    def __init__(self):
        self.effects, self.materials, self.geometries, self.nodes, self.lights = [], [], [], [], []

    def diffuse(self, name, rgb):
        self.effects.append(f"""    <effect id="{name}-effect">
      <profile_COMMON><technique sid="common"><phong>
        <diffuse><color sid="diffuse">{fmt(rgb)} 1</color></diffuse>
      </phong></technique></profile_COMMON>
    </effect>""")
        self.materials.append(f'    <material id="{name}" name="{name}"><instance_effect url="#{name}-effect"/></material>')

    def emissive(self, name, radiance):
        self.effects.append(f"""    <effect id="{name}-effect">
      <profile_COMMON><technique sid="common"><phong>
        <diffuse><color sid="diffuse">0 0 0 1</color></diffuse>
      </phong></technique></profile_COMMON>
      <extra><technique profile="CGL"><emission><radiance>{fmt(radiance)}</radiance></emission></technique></extra>
    </effect>""")
        self.materials.append(f'    <material id="{name}" name="{name}"><instance_effect url="#{name}-effect"/></material>')

    def mesh(self, name, positions, polygons, material, matrix=None):
        flat = [c for p in positions for c in p]
        vcount = " ".join(str(len(p)) for p in polygons)
        p = " ".join(str(i) for poly in polygons for i in poly)
        self.geometries.append(f"""    <geometry id="{name}-mesh" name="{name}">
      <mesh>
        <source id="{name}-positions">
          <float_array id="{name}-positions-array" count="{len(flat)}">{fmt(flat)}</float_array>
          <technique_common>
            <accessor source="#{name}-positions-array" count="{len(positions)}" stride="3">
              <param name="X" type="float"/><param name="Y" type="float"/><param name="Z" type="float"/>
            </accessor>
          </technique_common>
        </source>
        <vertices id="{name}-vertices"><input semantic="POSITION" source="#{name}-positions"/></vertices>
        <polylist material="{material}" count="{len(polygons)}">
          <input semantic="VERTEX" source="#{name}-vertices" offset="0"/>
          <vcount>{vcount}</vcount>
          <p>{p}</p>
        </polylist>
      </mesh>
    </geometry>""")
        self.node(name, f'<instance_geometry url="#{name}-mesh">{bind(material)}</instance_geometry>', matrix)

    def sphere(self, name, radius, center, material):
        self.geometries.append(f"""    <geometry id="{name}-data" name="{name}">
      <extra><technique profile="CGL"><sphere><radius>{radius}</radius></sphere></technique></extra>
    </geometry>""")
        self.node(name, f'<instance_geometry url="#{name}-data">{bind(material)}</instance_geometry>', translate(center))

    def light(self, name, kind, color, matrix=None):
        self.lights.append(f"""    <light id="{name}-light" name="{name}">
      <technique_common><point><color>{fmt(color)}</color></point></technique_common>
      <extra><technique profile="CGL"><{kind}><color>{fmt(color)}</color></{kind}></technique></extra>
    </light>""")
        self.node(name, f'<instance_light url="#{name}-light"/>', matrix)

    def node(self, name, content, matrix=None):
        m = matrix or identity()
        self.nodes.append(f"""      <node id="{name}-node" name="{name}" type="NODE">
        <matrix sid="transform">{fmt(m)}</matrix>
        {content}
      </node>""")

    def write(self, path, camera_matrix, xfov=49.13434, aspect=1.333333):
        # The renderer keeps only the camera's view direction, computed as
        # T·(0,0,−1,1) (translation included), and backs off from the scene
        # centre along it; so the translation here chooses the viewpoint.
        self.node("Camera", '<instance_camera url="#Camera-camera"/>', camera_matrix)
        text = f"""<?xml version="1.0" encoding="utf-8"?>
<!-- Written by scenes/generate.py -->
<COLLADA xmlns="http://www.collada.org/2005/11/COLLADASchema" version="1.4.1">
  <asset><unit name="meter" meter="1"/><up_axis>Y_UP</up_axis></asset>
  <library_cameras>
    <camera id="Camera-camera" name="Camera">
      <optics><technique_common><perspective>
        <xfov sid="xfov">{xfov}</xfov><aspect_ratio>{aspect}</aspect_ratio>
        <znear sid="znear">0.1</znear><zfar sid="zfar">100</zfar>
      </perspective></technique_common></optics>
    </camera>
  </library_cameras>
  <library_lights>
{chr(10).join(self.lights)}
  </library_lights>
  <library_effects>
{chr(10).join(self.effects)}
  </library_effects>
  <library_materials>
{chr(10).join(self.materials)}
  </library_materials>
  <library_geometries>
{chr(10).join(self.geometries)}
  </library_geometries>
  <library_visual_scenes>
    <visual_scene id="Scene" name="Scene">
{chr(10).join(self.nodes)}
    </visual_scene>
  </library_visual_scenes>
  <scene><instance_visual_scene url="#Scene"/></scene>
</COLLADA>
"""
        with open(os.path.join(HERE, path), "w") as f:
            f.write(text)


def bind(material):
    return (f'<bind_material><technique_common><instance_material symbol="{material}" '
            f'target="#{material}"/></technique_common></bind_material>')


def identity():
    return [1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1]


def translate(t):
    return [1, 0, 0, t[0], 0, 1, 0, t[1], 0, 0, 1, t[2], 0, 0, 0, 1]


def rotate_x(deg, t=(0, 0, 0)):
    c, s = math.cos(math.radians(deg)), math.sin(math.radians(deg))
    return [1, 0, 0, t[0], 0, c, -s, t[1], 0, s, c, t[2], 0, 0, 0, 1]


def quad(a, b, c, d):
    return [a, b, c, d], [[0, 1, 2, 3]]


def cornell():
    s = Scene()
    s.diffuse("white", (0.6, 0.6, 0.6))
    s.diffuse("red", (0.6, 0.2, 0.2))
    s.diffuse("blue", (0.2, 0.2, 0.6))
    s.diffuse("sphere", (0.8, 0.8, 0.8))
    # Open toward +z; the camera looks down −z.
    s.mesh("floor", *quad((-1, 0, -1), (-1, 0, 1), (1, 0, 1), (1, 0, -1)), "white")
    s.mesh("ceiling", *quad((-1, 1.5, -1), (1, 1.5, -1), (1, 1.5, 1), (-1, 1.5, 1)), "white")
    s.mesh("back", *quad((-1, 0, -1), (1, 0, -1), (1, 1.5, -1), (-1, 1.5, -1)), "white")
    s.mesh("left", *quad((-1, 0, -1), (-1, 1.5, -1), (-1, 1.5, 1), (-1, 0, 1)), "red")
    s.mesh("right", *quad((1, 0, -1), (1, 0, 1), (1, 1.5, 1), (1, 1.5, -1)), "blue")
    s.sphere("sphere1", 0.3, (-0.4, 0.3, -0.3), "sphere")
    s.sphere("sphere2", 0.3, (0.4, 0.3, 0.3), "sphere")
    # Area light: local −z is its normal; rotate so it faces down, just under the ceiling.
    m = rotate_x(-90, (0, 1.49, 0))
    m = [0.6 * m[0], 0.8 * m[1], m[2], m[3], 0.6 * m[4], 0.8 * m[5], m[6], m[7],
         0.6 * m[8], 0.8 * m[9], m[10], m[11], 0, 0, 0, 1]
    s.light("light", "area", (10, 10, 10), m)
    s.write("cornell.dae", translate((0, 0, 2)))


def cube_and_ball(lit):
    """A cube and a ball on a ground square: under a point light
    (point_light.dae), or with no light at all, for an environment map
    (outdoor.dae: `-e scenes/sky.exr`)."""
    s = Scene()
    s.diffuse("ground", (0.7, 0.7, 0.7))
    s.diffuse("orange", (0.8, 0.4, 0.1))
    s.diffuse("teal", (0.1, 0.6, 0.6))
    s.mesh("ground", *quad((-3, 0, -3), (-3, 0, 3), (3, 0, 3), (3, 0, -3)), "ground")
    # A unit cube resting on the ground.
    v = [(x, y, z) for x in (-0.5, 0.5) for y in (0, 1) for z in (-0.5, 0.5)]
    faces = [[0, 1, 3, 2], [4, 6, 7, 5], [0, 4, 5, 1], [2, 3, 7, 6], [0, 2, 6, 4], [1, 5, 7, 3]]
    s.mesh("cube", v, faces, "orange", translate((-0.8, 0, 0)))
    s.sphere("ball", 0.5, (0.9, 0.5, 0.3), "teal")
    if lit:
        s.light("lamp", "point", (6, 6, 6), translate((0.5, 3, 1.5)))
    s.write("point_light.dae" if lit else "outdoor.dae", translate((0, 1.2, 3)))


def sky_exr(path="sky.exr", width=512, height=256):
    """A latitude-longitude sky for `-e` (row 0 looks up, +y; the middle
    column along +x, as the CS184 renderer maps it): blue above, paler at
    the horizon, a sun 35 degrees up behind the default camera's left
    shoulder (a disc of 2 degrees radius: it spans a few texels), brown
    ground below. Written as an OpenEXR file by hand (float RGB, one
    zlib-compressed scanline per block), so no EXR library is needed."""
    import struct
    import zlib

    elevation, radius = math.radians(35), math.radians(2)
    sun = (-0.5 * math.cos(elevation), math.sin(elevation), 0.87 * math.cos(elevation))
    norm = math.sqrt(sum(c * c for c in sun))
    sun = [c / norm for c in sun]

    def radiance(d):
        if math.acos(max(-1.0, min(1.0, sum(a * b for a, b in zip(d, sun))))) < radius:
            return (600.0, 540.0, 450.0)
        if d[1] <= 0:
            return (0.15, 0.12, 0.09)
        t = math.sqrt(d[1])
        horizon, zenith = (0.55, 0.58, 0.6), (0.1, 0.18, 0.4)
        return tuple(h + (z - h) * t for h, z in zip(horizon, zenith))

    def attribute(name, kind, value):
        return name.encode() + b"\0" + kind.encode() + b"\0" + struct.pack("<i", len(value)) + value

    channels = b"".join(c + b"\0" + struct.pack("<iB3xii", 2, 0, 1, 1) for c in (b"B", b"G", b"R")) + b"\0"
    window = struct.pack("<iiii", 0, 0, width - 1, height - 1)
    header = (b"\x76\x2f\x31\x01" + struct.pack("<i", 2)
              + attribute("channels", "chlist", channels)
              + attribute("compression", "compression", bytes([2]))  # ZIPS
              + attribute("dataWindow", "box2i", window)
              + attribute("displayWindow", "box2i", window)
              + attribute("lineOrder", "lineOrder", bytes([0]))
              + attribute("pixelAspectRatio", "float", struct.pack("<f", 1.0))
              + attribute("screenWindowCenter", "v2f", struct.pack("<ff", 0.0, 0.0))
              + attribute("screenWindowWidth", "float", struct.pack("<f", 1.0))
              + b"\0")
    blocks = []
    for y in range(height):
        theta = (y + 0.5) / height * math.pi
        row = []
        for x in range(width):
            phi = (x + 0.5) / width * 2 * math.pi
            d = (-math.cos(phi) * math.sin(theta), math.cos(theta), math.sin(phi) * math.sin(theta))
            row.append(radiance(d))
        raw = b"".join(struct.pack(f"<{width}f", *(p[c] for p in row)) for c in (2, 1, 0))
        # OpenEXR's zip preprocessing: bytes split into even and odd
        # halves, then each byte stored as its difference from the last.
        split = raw[0::2] + raw[1::2]
        delta = bytes([split[0]] + [(split[i] - split[i - 1] + 128) & 0xFF for i in range(1, len(split))])
        packed = zlib.compress(delta, 9)
        data = packed if len(packed) < len(raw) else raw
        blocks.append(struct.pack("<ii", y, len(data)) + data)
    offset = len(header) + 8 * height
    table = b""
    for block in blocks:
        table += struct.pack("<Q", offset)
        offset += len(block)
    with open(os.path.join(HERE, path), "wb") as f:
        f.write(header + table + b"".join(blocks))


def torus_knot():
    s = Scene()
    s.diffuse("ground", (0.5, 0.5, 0.5))
    s.diffuse("knot", (0.75, 0.55, 0.3))
    s.mesh("ground", *quad((-4, 0, -4), (-4, 0, 4), (4, 0, 4), (4, 0, -4)), "ground")
    # A (2,3) torus knot tube: 240 × 16 quads.
    p_, q_, n_u, n_v, r_tube = 2, 3, 240, 16, 0.18

    def curve(t):
        r = 0.7 + 0.3 * math.cos(q_ * t)
        return (r * math.cos(p_ * t), 0.3 * math.sin(q_ * t) + 1.0, r * math.sin(p_ * t))

    verts = []
    for i in range(n_u):
        t = 2 * math.pi * i / n_u
        c, c2 = curve(t), curve(t + 1e-3)
        tangent = [c2[k] - c[k] for k in range(3)]
        ln = math.sqrt(sum(x * x for x in tangent))
        tangent = [x / ln for x in tangent]
        up = (0, 1, 0)
        nrm = [tangent[1] * up[2] - tangent[2] * up[1], tangent[2] * up[0] - tangent[0] * up[2],
               tangent[0] * up[1] - tangent[1] * up[0]]
        ln = math.sqrt(sum(x * x for x in nrm))
        nrm = [x / ln for x in nrm]
        bin_ = [tangent[1] * nrm[2] - tangent[2] * nrm[1], tangent[2] * nrm[0] - tangent[0] * nrm[2],
                tangent[0] * nrm[1] - tangent[1] * nrm[0]]
        for j in range(n_v):
            a = 2 * math.pi * j / n_v
            verts.append(tuple(c[k] + r_tube * (math.cos(a) * nrm[k] + math.sin(a) * bin_[k]) for k in range(3)))
    faces = []
    for i in range(n_u):
        for j in range(n_v):
            a, b = i * n_v + j, i * n_v + (j + 1) % n_v
            c, d = ((i + 1) % n_u) * n_v + (j + 1) % n_v, ((i + 1) % n_u) * n_v + j
            faces.append([a, d, c, b])
    s.mesh("knot", verts, faces, "knot")
    s.light("sky", "ambient", (0.4, 0.45, 0.5))
    # The direction toward a directional light is T·(0,0,−1,1): turning
    # −z by 130° about x points it up and toward the camera (+z), so the sun
    # stands 50° above the floor behind the viewer. (−50° put it below.)
    s.light("sun", "directional", (2.0, 1.9, 1.7), rotate_x(130))
    s.write("torus_knot.dae", translate((0, 1.5, 3)))


if __name__ == "__main__":
    cornell()
    cube_and_ball(lit=True)
    cube_and_ball(lit=False)
    sky_exr()
    torus_knot()

#!/usr/bin/env python3
"""Writes the small glTF files of tests/geometry/light_import_test.cpp into tests/data (run once; the
files are committed): a 20 x 20 floor at y = 0 (front up, grey albedo 0.5) lit by
  spot.gltf         a KHR_lights_punctual spot at (0, 2, 0) pointing down (intensity 10 cd,
                    colour 1, 0.5, 0.25, innerConeAngle 0.3, outerConeAngle 0.6, range 100),
  directional.gltf  a directional light of 3 lux travelling along (0.5, -0.866, 0) (30 degrees
                    from straight down),
and emissive_strength.gltf, tests/data/lamp.gltf with KHR_materials_emissive_strength 4 on its
lamp material. Buffers are data URIs (one file each)."""
import base64, json, math, os, struct

HERE = os.path.dirname(os.path.abspath(__file__))

def quat_mul(a, b):
    ax, ay, az, aw = a
    bx, by, bz, bw = b
    return [aw * bx + ax * bw + ay * bz - az * by,
            aw * by - ax * bz + ay * bw + az * bx,
            aw * bz + ax * by - ay * bx + az * bw,
            aw * bw - ax * bx - ay * by - az * bz]

def axis_angle(axis, deg):
    h = math.radians(deg) / 2
    return [axis[0] * math.sin(h), axis[1] * math.sin(h), axis[2] * math.sin(h), math.cos(h)]

def floor_scene(light, light_node):
    pos = [(-10, 0, 10), (10, 0, 10), (10, 0, -10), (-10, 0, -10)]
    idx = [0, 1, 2, 0, 2, 3]
    raw = b"".join(struct.pack("<3f", *p) for p in pos) + struct.pack("<6H", *idx)
    return {
        "asset": {"version": "2.0", "generator": "photonflow tests/data/make_punctual_gltf.py"},
        "extensionsUsed": ["KHR_lights_punctual"],
        "extensions": {"KHR_lights_punctual": {"lights": [light]}},
        "scene": 0,
        "scenes": [{"nodes": [0, 1]}],
        "nodes": [{"name": "floor", "mesh": 0},
                  dict(light_node, extensions={"KHR_lights_punctual": {"light": 0}})],
        "meshes": [{"name": "floor", "primitives": [{"attributes": {"POSITION": 0},
                                                      "indices": 1, "material": 0}]}],
        "materials": [{"name": "floor", "pbrMetallicRoughness": {
            "baseColorFactor": [0.5, 0.5, 0.5, 1], "metallicFactor": 0}}],
        "buffers": [{"byteLength": len(raw), "uri": "data:application/octet-stream;base64," +
                     base64.b64encode(raw).decode()}],
        "bufferViews": [{"buffer": 0, "byteOffset": 0, "byteLength": 48},
                        {"buffer": 0, "byteOffset": 48, "byteLength": 12}],
        "accessors": [{"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3",
                       "min": [-10, 0, -10], "max": [10, 0, 10]},
                      {"bufferView": 1, "componentType": 5123, "count": 6, "type": "SCALAR"}],
    }

def write(name, doc):
    with open(os.path.join(HERE, name), "w") as f:
        json.dump(doc, f, indent=1)
        f.write("\n")

down = axis_angle((1, 0, 0), -90)  # the light's -z onto -y
write("spot.gltf", floor_scene(
    {"name": "spot", "type": "spot", "color": [1, 0.5, 0.25], "intensity": 10, "range": 100,
     "spot": {"innerConeAngle": 0.3, "outerConeAngle": 0.6}},
    {"name": "spot", "translation": [0, 2, 0], "rotation": down}))
write("directional.gltf", floor_scene(
    {"name": "sun", "type": "directional", "color": [1, 1, 1], "intensity": 3},
    {"name": "sun", "translation": [0, 50, 0],
     "rotation": quat_mul(axis_angle((0, 0, 1), 30), down)}))
with open(os.path.join(HERE, "lamp.gltf")) as f:
    lamp = json.load(f)
lamp["asset"]["generator"] = "photonflow tests/data/make_punctual_gltf.py (lamp.gltf + strength)"
lamp["extensionsUsed"] = ["KHR_materials_emissive_strength"]
lamp["materials"][0]["extensions"] = {"KHR_materials_emissive_strength": {"emissiveStrength": 4}}
write("emissive_strength.gltf", lamp)

# The same as a binary glTF: JSON chunk (buffer 0 without uri) and BIN chunk (glTF 2.0 §4.4).
glb_doc = json.loads(json.dumps(lamp))
raw = base64.b64decode(glb_doc["buffers"][0].pop("uri").split(",", 1)[1])
raw += b"\0" * (-len(raw) % 4)
glb_doc["buffers"][0]["byteLength"] = len(raw)
text = json.dumps(glb_doc, separators=(",", ":")).encode()
text += b" " * (-len(text) % 4)
with open(os.path.join(HERE, "emissive_strength.glb"), "wb") as f:
    f.write(b"glTF" + struct.pack("<II", 2, 12 + 8 + len(text) + 8 + len(raw)))
    f.write(struct.pack("<I", len(text)) + b"JSON" + text)
    f.write(struct.pack("<I", len(raw)) + b"BIN\0" + raw)

"""Test avatars made from mimika's own exports: a GLB opened as JSON + binary, edited the way
other tools name and pose their characters (Ready Player Me, VRoid/VRM, Character Creator …),
and written back. No third-party avatar is needed."""

from __future__ import annotations

import json
import math
import struct
from pathlib import Path

import numpy as np

_COMPONENT = {np.dtype(np.float32): 5126, np.dtype(np.uint32): 5125,
              np.dtype(np.uint16): 5123}
_TYPE = {1: "SCALAR", 2: "VEC2", 3: "VEC3", 4: "VEC4", 16: "MAT4"}


class Glb:
    """A GLB file's JSON (``doc``) and binary chunk, editable."""

    def __init__(self, path: str | Path) -> None:
        data = Path(path).read_bytes()
        n = struct.unpack_from("<I", data, 12)[0]
        self.doc = json.loads(data[20:20 + n])
        off = 20 + n
        self.bin = bytearray(data[off + 8:off + 8 + struct.unpack_from("<I", data, off)[0]])

    def node(self, name: str) -> int:
        return next(i for i, n in enumerate(self.doc["nodes"]) if n.get("name") == name)

    def mesh_node(self, mesh_name: str) -> int:
        mesh = next(i for i, m in enumerate(self.doc["meshes"]) if m["name"] == mesh_name)
        return next(i for i, n in enumerate(self.doc["nodes"]) if n.get("mesh") == mesh)

    def add(self, a: np.ndarray, target: int | None = None) -> int:
        """Append ``a`` (float32 (N, k) or integer indices) as an accessor; its index."""
        a = np.ascontiguousarray(a)
        a = a.astype(np.uint32 if a.dtype.kind in "iu" else np.float32)
        while len(self.bin) % 4:
            self.bin.append(0)
        view = {"buffer": 0, "byteOffset": len(self.bin), "byteLength": a.nbytes}
        if target is not None:
            view["target"] = target
        self.bin += a.tobytes()
        self.doc["bufferViews"].append(view)
        width = 1 if a.ndim == 1 else a.shape[1]
        acc = {"bufferView": len(self.doc["bufferViews"]) - 1,
               "componentType": _COMPONENT[a.dtype], "count": len(a),
               "type": _TYPE[width]}
        if a.dtype == np.float32 and width == 3:
            acc["min"] = a.min(0).tolist()
            acc["max"] = a.max(0).tolist()
        self.doc["accessors"].append(acc)
        return len(self.doc["accessors"]) - 1

    def array(self, index: int) -> np.ndarray:
        """A plain float32 VEC3 accessor (no sparse, no stride) as (N, 3)."""
        acc = self.doc["accessors"][index]
        view = self.doc["bufferViews"][acc["bufferView"]]
        off = view.get("byteOffset", 0) + acc.get("byteOffset", 0)
        return np.frombuffer(bytes(self.bin[off:off + 12 * acc["count"]]), np.float32
                             ).reshape(-1, 3).copy()

    def add_morphs(self, mesh_name: str, morphs: dict[str, np.ndarray]) -> None:
        """Morph targets ``name → (N, 3) deltas`` on every primitive of mesh ``mesh_name``
        (its primitives share one vertex array, as mimika writes them)."""
        mesh = next(m for m in self.doc["meshes"] if m["name"] == mesh_name)
        ids = {k: self.add(d) for k, d in morphs.items()}
        for p in mesh["primitives"]:
            p["targets"] = p.get("targets", []) + [{"POSITION": i} for i in ids.values()]
        extras = mesh.setdefault("extras", {})
        extras["targetNames"] = extras.get("targetNames", []) + list(ids)
        mesh["weights"] = mesh.get("weights", []) + [0.0] * len(ids)

    def rename(self, names: dict[str, str]) -> None:
        """Nodes, meshes and materials renamed by ``names`` (old → new)."""
        for key in ("nodes", "meshes", "materials"):
            for item in self.doc.get(key, []):
                if item.get("name") in names:
                    item["name"] = names[item["name"]]

    def drop_morphs(self) -> None:
        """No morph targets at all: every AU then comes from the fallback fields."""
        for m in self.doc["meshes"]:
            for p in m["primitives"]:
                p.pop("targets", None)
            m.pop("weights", None)
            m.pop("extras", None)
        self.doc.pop("animations", None)

    def add_mesh(self, name: str, vertices: np.ndarray, faces: np.ndarray,
                 parent: int | None, color=(0.05, 0.05, 0.05, 1.0)) -> int:
        """A static mesh node ``name`` (a child of node ``parent``, or a root), its own
        material; the node index."""
        self.doc["materials"].append({"name": name, "pbrMetallicRoughness": {
            "baseColorFactor": list(color), "metallicFactor": 0.0}})
        prim = {"attributes": {"POSITION": self.add(vertices, 34962)},
                "indices": self.add(faces.reshape(-1), 34963),
                "material": len(self.doc["materials"]) - 1}
        self.doc["meshes"].append({"name": name, "primitives": [prim]})
        self.doc["nodes"].append({"name": name, "mesh": len(self.doc["meshes"]) - 1})
        ni = len(self.doc["nodes"]) - 1
        if parent is None:
            self.doc["scenes"][self.doc.get("scene", 0)]["nodes"].append(ni)
        else:
            self.doc["nodes"][parent].setdefault("children", []).append(ni)
        return ni

    def set_world_rotation(self, node: int, world: np.ndarray, rot: np.ndarray) -> None:
        """Turn ``node`` (with its children) by ``rot`` (3, 3) about its own position in the
        world, given the file's rest world matrices ``world`` (nodes, 4, 4)."""
        parent = next((i for i, n in enumerate(self.doc["nodes"])
                       if node in n.get("children", [])), None)
        d = np.eye(4)
        d[:3, :3] = rot
        p = world[node, :3, 3]
        d[:3, 3] = p - rot @ p
        pw = world[parent] if parent is not None else np.eye(4)
        local = np.linalg.inv(pw) @ d @ world[node]
        nd = self.doc["nodes"][node]
        for k in ("translation", "rotation", "scale"):
            nd.pop(k, None)
        nd["matrix"] = local.T.reshape(-1).tolist()

    def save(self, path: str | Path) -> Path:
        self.doc["buffers"] = [{"byteLength": len(self.bin)}]
        js = json.dumps(self.doc).encode()
        js += b" " * (-len(js) % 4)
        while len(self.bin) % 4:
            self.bin.append(0)
        out = struct.pack("<III", 0x46546C67, 2, 28 + len(js) + len(self.bin))
        out += struct.pack("<II", len(js), 0x4E4F534A) + js
        out += struct.pack("<II", len(self.bin), 0x004E4942) + bytes(self.bin)
        Path(path).write_bytes(out)
        return Path(path)


def rot_z(deg: float) -> np.ndarray:
    """Rotation (3, 3) of ``deg`` degrees about +z."""
    c, s = math.cos(math.radians(deg)), math.sin(math.radians(deg))
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def _rot(axis: int, deg: float) -> np.ndarray:
    c, s = math.cos(math.radians(deg)), math.sin(math.radians(deg))
    i, j = [(1, 2), (2, 0), (0, 1)][axis]
    r = np.eye(3)
    r[i, i] = r[j, j] = c
    r[i, j], r[j, i] = -s, s
    return r


#: Ready Player Me's eyeball morphs turn the eye about this much at weight 1 (degrees)
RPM_EYE_MORPH_DEG = 26.0


def eye_look_morphs(v: np.ndarray, side: str, deg: float = RPM_EYE_MORPH_DEG
                    ) -> dict[str, np.ndarray]:
    """ARKit eyeLook morphs that turn an eyeball (vertices ``v`` about their origin, y up,
    facing +z) by ``deg``, as Ready Player Me's EyeLeft/EyeRight carry them."""
    out_sign = 1.0 if side == "Left" else -1.0  # out: toward the subject's own side
    turns = {"Out": (1, out_sign * deg), "In": (1, -out_sign * deg), "Up": (0, -deg),
             "Down": (0, deg)}
    return {f"eyeLook{k}{side}": (v @ _rot(a, d).T - v).astype(np.float32)
            for k, (a, d) in turns.items()}


def glasses(eye_l: np.ndarray, eye_r: np.ndarray, front: float, radius: float = 0.022,
            bar: float = 0.003, n: int = 24) -> tuple[np.ndarray, np.ndarray]:
    """A pair of glasses (metres, y up, facing +z): two rims of ``radius`` round the eyes
    ``front`` in front of them and a bridge; (vertices, triangles)."""
    verts, faces = [], []

    def ring(c: np.ndarray) -> None:
        base = len(verts)
        for k in range(n):
            a = 2 * math.pi * k / n
            d = np.array([math.cos(a), math.sin(a), 0.0])
            verts.extend([c + radius * d, c + (radius + bar) * d])
        for k in range(n):
            i, j = base + 2 * k, base + 2 * ((k + 1) % n)
            faces.extend([(i, j, i + 1), (j, j + 1, i + 1)])

    z = np.array([0.0, 0.0, front])
    ring(eye_l + z)
    ring(eye_r + z)
    a, b = eye_l + z - np.array([radius, 0, 0]), eye_r + z + np.array([radius, 0, 0])
    up = np.array([0.0, bar, 0.0])
    base = len(verts)
    verts.extend([a, b, a + up, b + up])
    faces.extend([(base, base + 1, base + 2), (base + 1, base + 3, base + 2)])
    return np.asarray(verts, np.float32), np.asarray(faces, np.int64)


#: mimika's export names → Ready Player Me's (meshes, nodes, materials and bones)
RPM_NAMES = {"skin": "Wolf3D_Head", "eye_L": "EyeLeft", "eye_R": "EyeRight",
             "teeth": "Wolf3D_Teeth", "hair": "Wolf3D_Hair", "hair_coily": "Wolf3D_Hair",
             "clothes": "Wolf3D_Outfit_Top", "cloth": "Wolf3D_Outfit_Top",
             "head": "Head", "neck01": "Neck", "upperarm01.L": "LeftArm",
             "upperarm01.R": "RightArm", "lowerarm01.L": "LeftForeArm",
             "lowerarm01.R": "RightForeArm", "lips": "Wolf3D_Skin_Lips"}


def ready_player_me(src: Path, dst: Path, *, t_pose: bool = False, morphs: bool = True,
                    with_glasses: bool = False, eye_morphs: bool = False) -> Path:
    """mimika's export of a character ``src`` named like a Ready Player Me avatar
    (Wolf3D_Head, EyeLeft, Wolf3D_Hair, Wolf3D_Outfit_Top, Head, LeftArm …), optionally
    in a T pose (the upper arms raised through the skeleton), without morphs, with
    Wolf3D_Glasses on the head, or with eyeLook morphs that turn the eye meshes (the skin's
    own eye-AU morphs then renamed away, so the eye AUs read the ARKit eyeLook shapes)."""
    from mimika.face.heads.gltf_scene import read_gltf

    g = Glb(src)
    world = read_gltf(src).node_world
    if t_pose:
        for bone, sign in (("upperarm01.L", 1), ("upperarm01.R", -1)):
            j = g.node(bone)
            kid = g.doc["nodes"][j]["children"][0]
            arm = world[kid, :3, 3] - world[j, :3, 3]
            ang = math.degrees(math.atan2(arm[1], arm[0] * sign))  # from sideways
            g.set_world_rotation(j, world, rot_z(-sign * ang))
    if not morphs:
        g.drop_morphs()
    if eye_morphs:
        for mesh, side in (("eye_L", "Left"), ("eye_R", "Right")):
            prim = next(m for m in g.doc["meshes"] if m["name"] == mesh)["primitives"][0]
            g.add_morphs(mesh, eye_look_morphs(g.array(prim["attributes"]["POSITION"]), side))
        for m in g.doc["meshes"]:
            names = m.get("extras", {}).get("targetNames", [])
            names[:] = [f"x{n}" if n[:4] in ("AU61", "AU62", "AU63", "AU64") else n
                        for n in names]
    if with_glasses:
        sc = read_gltf(src)
        eyes = {m.name: m.vertices.mean(0) for m in sc.meshes if m.name in ("eye_L", "eye_R")}
        v, f = glasses(eyes["eye_L"], eyes["eye_R"], front=0.025)
        head = g.node("head")
        inv = np.linalg.inv(world[head])
        g.add_mesh("Wolf3D_Glasses", (v @ inv[:3, :3].T + inv[:3, 3]).astype(np.float32), f,
                   head)
    g.rename(RPM_NAMES)
    return g.save(dst)


#: mimika's builtin materials → VRoid's (VRM) material names
VROID_MATERIALS = {"skin": "N00_000_00_Face_00_SKIN (Instance)",
                   "socket": "N00_000_00_EyeWhite_00_EYE (Instance)",
                   "brow": "N00_000_00_FaceBrow_00_FACE (Instance)",
                   "iris": "N00_000_00_EyeIris_00_EYE (Instance)",
                   "teeth": "N00_000_00_FaceMouth_00_FACE (Instance)"}
#: VRM 1.0 expression → the builtin export's AU morphs it binds (0.x names in VRM0_NAMES)
VRM_EXPRESSIONS = {"blink": ["AU45"], "blinkLeft": ["AU46L"], "blinkRight": ["AU46R"],
                   "happy": ["AU06", "AU12"], "angry": ["AU04", "AU23"],
                   "sad": ["AU01", "AU15"], "surprised": ["AU02", "AU05"],
                   "relaxed": ["AU12"], "aa": ["AU27"], "ih": ["AU20"], "ou": ["AU18"],
                   "ee": ["AU25"], "oh": ["AU22"]}
VRM0_NAMES = {"blinkLeft": "blink_l", "blinkRight": "blink_r", "happy": "joy",
              "sad": "sorrow", "relaxed": "fun", "aa": "a", "ih": "i", "ou": "u", "ee": "e",
              "oh": "o"}
#: lookAt ranges: a 30° gaze turns the eye bones 30 / 90 · 10 = 3.3°
LOOK_RANGE = (90.0, 10.0)


def vrm(src: Path, dst: Path, version: int) -> Path:
    """mimika's builtin export ``src`` as a minimal VRM ``version`` 0 or 1 file, per the
    spec: humanoid neck, head and eye bones, the expressions of :data:`VRM_EXPRESSIONS`
    bound to its morphs (whose own names are hidden), bone lookAt ranges, MToon materials
    named like VRoid's (0.x: their colour only in MToon's ``_Color``); a 0.x file faces −z
    as 0.x files do."""
    g = Glb(src)
    names = g.doc["meshes"][0]["extras"]["targetNames"]
    index = {n: k for k, n in enumerate(names)}
    for m in g.doc["meshes"]:
        if "extras" in m:
            m["extras"]["targetNames"] = [f"morph{k}" for k in range(len(
                m["extras"]["targetNames"]))]
    g.rename(VROID_MATERIALS | {"skin": "Face"})
    skin_node = g.mesh_node("Face")
    bones = {"neck": g.node("neck"), "head": g.node("head"), "leftEye": g.node("eye_L"),
             "rightEye": g.node("eye_R")}
    top, scale = LOOK_RANGE
    if version == 1:
        for m in g.doc["materials"]:
            m["extensions"] = {"VRMC_materials_mtoon": {"specVersion": "1.0"}}
        rng = {"inputMaxValue": top, "outputScale": scale}
        g.doc["extensions"] = {"VRMC_vrm": {
            "specVersion": "1.0", "meta": {"name": "mimika test", "licenseUrl": "CC0"},
            "humanoid": {"humanBones": {b: {"node": n} for b, n in bones.items()}},
            "lookAt": {"type": "bone", **{k: dict(rng) for k in (
                "rangeMapHorizontalInner", "rangeMapHorizontalOuter", "rangeMapVerticalDown",
                "rangeMapVerticalUp")}},
            "expressions": {"preset": {e: {"morphTargetBinds": [
                {"node": skin_node, "index": index[a], "weight": 1.0} for a in aus]}
                for e, aus in VRM_EXPRESSIONS.items()}}}}
        g.doc["extensionsUsed"] = ["VRMC_vrm", "VRMC_materials_mtoon"]
    else:
        rng = {"curve": [0, 0, 0, 1, 1, 1, 1, 0], "xRange": top, "yRange": scale}
        g.doc["extensions"] = {"VRM": {
            "specVersion": "0.0", "meta": {"title": "mimika test"},
            "humanoid": {"humanBones": [{"bone": b, "node": n} for b, n in bones.items()]},
            "firstPerson": {"lookAtTypeName": "Bone", **{k: dict(rng) for k in (
                "lookAtHorizontalInner", "lookAtHorizontalOuter", "lookAtVerticalDown",
                "lookAtVerticalUp")}},
            "blendShapeMaster": {"blendShapeGroups": [
                {"name": VRM0_NAMES.get(e, e).capitalize(), "presetName": VRM0_NAMES.get(e, e),
                 "binds": [{"mesh": 0, "index": index[a], "weight": 100} for a in aus]}
                for e, aus in VRM_EXPRESSIONS.items()]},
            "materialProperties": [{"name": m["name"], "shader": "VRM/MToon",
                                    "vectorProperties": {"_Color": m.pop(
                                        "pbrMetallicRoughness")["baseColorFactor"]},
                                    "textureProperties": {}} for m in g.doc["materials"]]}}
        g.doc["extensionsUsed"] = ["VRM"]
        scene = g.doc["scenes"][g.doc.get("scene", 0)]
        g.doc["nodes"].append({"name": "Root", "rotation": [0.0, 1.0, 0.0, 0.0],
                               "children": scene["nodes"]})
        scene["nodes"] = [len(g.doc["nodes"]) - 1]
    return g.save(dst)

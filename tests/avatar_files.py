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
                    with_glasses: bool = False) -> Path:
    """mimika's export of a character ``src`` named like a Ready Player Me avatar
    (Wolf3D_Head, EyeLeft, Wolf3D_Hair, Wolf3D_Outfit_Top, Head, LeftArm …), optionally
    in a T pose (the upper arms raised through the skeleton), without morphs, with
    Wolf3D_Glasses on the head."""
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

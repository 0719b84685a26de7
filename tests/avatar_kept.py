"""Test avatars for the faithful export, written by the tests from mimika's builtin export:
a skeleton of six joints turned as Blender exports them under a 0.01 scale (the head joint
a matrix), ARKit-named morphs (one of them
empty), a custom morph, named PBR materials with a JPEG base colour shared by two materials,
normal, occlusion/metallic-roughness (one image) and emissive maps, KHR_texture_transform,
a MASK material — and a player-side evaluation of an animated glTF (morph weights, skinning,
node animation) to compare with the rig."""

from __future__ import annotations

import io
from pathlib import Path

import numpy as np
from PIL import Image
from scipy.spatial.transform import Rotation

from avatar_files import Glb

#: builtin export morph → the ARKit name it stands for in the test avatar (others dropped)
ARKIT = {"AU26": "jawOpen", "AU12L": "mouthSmileLeft", "AU12R": "mouthSmileRight",
         "AU43L": "eyeBlinkLeft", "AU43R": "eyeBlinkRight", "AU01": "browInnerUp",
         "AU15L": "mouthFrownLeft", "AU15R": "mouthFrownRight"}
#: joints of the test skeleton, root first: name → (builtin node it stands for or None,
#: world orientation as Blender exports bones: rotation vector, degrees)
JOINTS = {"Hips": (None, (-90.0, 0.0, 0.0)), "Spine": (None, (-80.0, 0.0, 10.0)),
          "Neck": ("neck", (-75.0, 0.0, 0.0)), "Head": ("head", (-90.0, 5.0, 0.0)),
          "LeftEye": ("eye_L", (0.0, 180.0, 0.0)), "RightEye": ("eye_R", (0.0, 180.0, 0.0))}
#: the world scale of every joint (an armature in cm placed in a metre scene)
ARMATURE_SCALE = 0.01
MATERIALS = {"skin": "Wolf3D_Skin", "lips": "Wolf3D_Lips", "brow": "Wolf3D_Brows",
             "sclera": "Wolf3D_Eye", "teeth": "Wolf3D_Teeth"}


def _trs(m: np.ndarray) -> dict:
    """A rigid, uniformly scaled 4×4 matrix as glTF translation, rotation and scale."""
    s = float(np.cbrt(np.linalg.det(m[:3, :3])))
    return {"translation": m[:3, 3].tolist(),
            "rotation": Rotation.from_matrix(m[:3, :3] / s).as_quat().tolist(),
            "scale": [s] * 3}


def _image(fmt: str, size: int, rgba: bool = False, seed: int = 0) -> bytes:
    rng = np.random.default_rng(seed)
    y, x = np.mgrid[0:size, 0:size] / size
    img = np.stack([200 * x + 30, 120 + 60 * y, 90 + 40 * x * y], -1)
    img = img + rng.normal(0, 12, img.shape)
    if rgba:
        img = np.concatenate([img, 255 * (rng.random((size, size, 1)) > 0.4)], -1)
    buf = io.BytesIO()
    Image.fromarray(np.clip(img, 0, 255).astype(np.uint8)).save(buf, format=fmt, quality=88)
    return buf.getvalue()


def _raw(g: Glb, index: int, dtype, width: int) -> np.ndarray:
    acc = g.doc["accessors"][index]
    view = g.doc["bufferViews"][acc["bufferView"]]
    off = view.get("byteOffset", 0) + acc.get("byteOffset", 0)
    n = acc["count"] * width
    return np.frombuffer(bytes(g.bin[off:off + n * np.dtype(dtype).itemsize]), dtype
                         ).reshape(acc["count"], width).copy()


def _append(g: Glb, data: bytes, acc: dict | None = None, target: int | None = None) -> int:
    while len(g.bin) % 4:
        g.bin.append(0)
    view = {"buffer": 0, "byteOffset": len(g.bin), "byteLength": len(data)}
    if target is not None:
        view["target"] = target
    g.bin += data
    g.doc["bufferViews"].append(view)
    if acc is None:
        return len(g.doc["bufferViews"]) - 1
    g.doc["accessors"].append({**acc, "bufferView": len(g.doc["bufferViews"]) - 1})
    return len(g.doc["accessors"]) - 1


def _world(doc: dict, local: np.ndarray | None = None) -> np.ndarray:
    """World matrices of all nodes from their ``local`` ones (default: the rest TRS or
    matrix of each node)."""
    nodes = doc["nodes"]
    n = len(nodes)
    if local is None:
        local = np.stack([_local(nd) for nd in nodes])
    parent = np.full(n, -1)
    for i, nd in enumerate(nodes):
        for c in nd.get("children", []):
            parent[c] = i
    world = np.zeros_like(local)
    done = np.zeros(n, bool)
    while not done.all():
        for i in range(n):
            if not done[i] and (parent[i] < 0 or done[parent[i]]):
                world[i] = local[i] if parent[i] < 0 else world[parent[i]] @ local[i]
                done[i] = True
    return world


def _local(nd: dict, t=None, r=None, s=None) -> np.ndarray:
    if "matrix" in nd and t is None and r is None:
        return np.asarray(nd["matrix"], float).reshape(4, 4).T
    m = np.eye(4)
    m[:3, :3] = Rotation.from_quat(r if r is not None else nd.get("rotation", [0, 0, 0, 1])
                                   ).as_matrix() * np.asarray(nd.get("scale", [1, 1, 1]))
    m[:3, 3] = t if t is not None else nd.get("translation", [0, 0, 0])
    return m


def arkit_avatar(src: Path, dst: Path) -> Path:
    """The builtin export ``src`` as an avatar of the kind people bring (see module doc)."""
    g = Glb(src)
    doc = g.doc
    world0 = _world(doc)
    names = {nd["name"]: i for i, nd in enumerate(doc["nodes"])}
    # the skeleton: new joint nodes with Blender-like orientations at the builtin's places
    joint_world = {}
    pos = {"Hips": world0[names["neck"], :3, 3] - [0, 0.35, 0],
           "Spine": world0[names["neck"], :3, 3] - [0, 0.15, 0]}
    for j, (old, rv) in JOINTS.items():  # an armature in cm under a 0.01 scale (FBX-like)
        m = np.eye(4)
        m[:3, :3] = Rotation.from_rotvec(np.radians(rv)).as_matrix() * ARMATURE_SCALE
        m[:3, 3] = pos[j] if old is None else world0[names[old], :3, 3]
        joint_world[j] = m
    parents = {"Hips": None, "Spine": "Hips", "Neck": "Spine", "Head": "Neck",
               "LeftEye": "Head", "RightEye": "Head"}
    first = len(doc["nodes"])
    jn = {j: first + k for k, j in enumerate(JOINTS)}
    for j in JOINTS:
        p = parents[j]
        loc = joint_world[j] if p is None else np.linalg.inv(joint_world[p]) @ joint_world[j]
        doc["nodes"].append({"name": j, **_trs(loc)})
        if j == "Head":  # stored as a matrix, as some exporters do
            doc["nodes"][-1] = {"name": j, "matrix": loc.T.reshape(-1).tolist()}
    for j, p in parents.items():
        if p is not None:
            doc["nodes"][jn[p]].setdefault("children", []).append(jn[j])
    # eye meshes hang under the eye joints (where they were); the old joints go
    for eye, j in (("eye_L", "LeftEye"), ("eye_R", "RightEye")):
        loc = np.linalg.inv(joint_world[j]) @ world0[names[eye]]
        nd = doc["nodes"][names[eye]]
        nd["name"] = {"eye_L": "EyeLeft", "eye_R": "EyeRight"}[eye]
        nd.update(_trs(loc))
        doc["nodes"][jn[j]]["children"] = [names[eye]]
    for old in ("neck", "head"):
        doc["nodes"][names[old]] = {"name": f"x{len(old)}{old[0]}"}  # unused, not a bone
    scene = doc["scenes"][0]
    scene["nodes"] = [jn["Hips"]] + [i for i in scene["nodes"] if i != names["neck"]]
    ibm = np.stack([np.linalg.inv(joint_world[j]).T for j in JOINTS]).astype(np.float32)
    doc["skins"] = [{"name": "Armature", "joints": [jn[j] for j in JOINTS],
                     "skeleton": jn["Hips"],
                     "inverseBindMatrices": _append(g, ibm.tobytes(), {
                         "componentType": 5126, "count": len(JOINTS), "type": "MAT4"})}]
    done = {}
    for m in doc["meshes"]:
        for p in m["primitives"]:
            a = p["attributes"]
            if "JOINTS_0" in a:  # neck, head → Neck, Head (indices 2 and 3 of the skin)
                if a["JOINTS_0"] not in done:
                    jt = _raw(g, a["JOINTS_0"], np.uint16, 4) + 2
                    done[a["JOINTS_0"]] = _append(g, jt.astype(np.uint16).tobytes(), {
                        "componentType": 5123, "count": len(jt), "type": "VEC4"}, 34962)
                a["JOINTS_0"] = done[a["JOINTS_0"]]
    _morphs(g)
    _materials(g)
    g.rename({"skin": "Wolf3D_Head", "brows": "Wolf3D_Brows", "teeth_upper": "Wolf3D_Teeth",
              "teeth_lower": "Wolf3D_TeethLower", "tongue": "Wolf3D_Tongue"})
    return g.save(dst)


def _morphs(g: Glb) -> None:
    """Morphs renamed to ARKit (+ an empty mouthFunnel and a custom one on the skin)."""
    for m in g.doc["meshes"]:
        names = m.get("extras", {}).get("targetNames")
        if not names:
            continue
        keep = [k for k, n in enumerate(names) if n in ARKIT]
        new = [ARKIT[names[k]] for k in keep]
        custom = names.index("AU14") if "AU14" in names else None
        prims = m["primitives"]
        targets = prims[0]["targets"]
        kept = [targets[k] for k in keep]
        if m["name"] == "skin":
            n_v = g.doc["accessors"][prims[0]["attributes"]["POSITION"]]["count"]
            zero = _append(g, np.zeros((n_v, 3), np.float32).tobytes(), {
                "componentType": 5126, "count": n_v, "type": "VEC3", "min": [0.0] * 3,
                "max": [0.0] * 3})
            kept += [{"POSITION": zero}, targets[custom]]
            new += ["mouthFunnel", "customSmirk"]
        for p in prims:
            p["targets"] = kept
        m["extras"]["targetNames"] = new
        m["weights"] = [0.0] * len(new)


def _materials(g: Glb) -> None:
    """Named PBR materials with textures (see the module doc) and UVs on the textured
    meshes."""
    doc = g.doc
    jpeg, normal, orm, mask = (_image("JPEG", 128, seed=1), _image("PNG", 64, seed=2),
                               _image("PNG", 48, seed=3), _image("PNG", 32, True, seed=4))
    views = [_append(g, b) for b in (jpeg, normal, orm, mask)]
    doc["images"] = [{"name": n, "bufferView": v, "mimeType": t} for n, v, t in zip(
        ("skin_color", "skin_normal", "skin_orm", "brows"), views,
        ("image/jpeg", "image/png", "image/png", "image/png"), strict=True)]
    doc["samplers"] = [{"magFilter": 9729, "minFilter": 9987}]
    doc["textures"] = [{"sampler": 0, "source": i} for i in (0, 1, 2, 3, 0)]
    for mat in doc["materials"]:
        old = mat["name"]
        mat["name"] = MATERIALS.get(old, old)
        pbr = mat["pbrMetallicRoughness"]
        if old in ("skin", "lips"):
            pbr.update({"baseColorTexture": {"index": 0 if old == "skin" else 4, "extensions": {
                "KHR_texture_transform": {"offset": [0.05, 0.0], "scale": [0.9, 0.9]}}},
                "metallicFactor": 0.1, "roughnessFactor": 0.8,
                "metallicRoughnessTexture": {"index": 2}})
            mat.update({"normalTexture": {"index": 1, "scale": 0.7},
                        "occlusionTexture": {"index": 2, "strength": 0.9},
                        "emissiveTexture": {"index": 0}, "emissiveFactor": [0.05, 0.02, 0.02],
                        "extensions": {"KHR_materials_emissive_strength": {
                            "emissiveStrength": 1.5}}})
        elif old == "brow":
            pbr.update({"baseColorTexture": {"index": 3}, "roughnessFactor": 0.9})
            mat.update({"alphaMode": "MASK", "alphaCutoff": 0.35, "doubleSided": True})
    doc["extensionsUsed"] = ["KHR_texture_transform", "KHR_materials_emissive_strength"]
    uv_of = {}
    for m in doc["meshes"]:
        if m["name"] not in ("skin", "brows"):
            continue
        for p in m["primitives"]:
            a = p["attributes"]
            if a["POSITION"] not in uv_of:
                v = g.array(a["POSITION"])
                uv = np.c_[v[:, 0] / 0.2 + 0.5, 0.5 - v[:, 1] / 0.3].astype(np.float32)
                uv_of[a["POSITION"]] = _append(g, uv.tobytes(), {
                    "componentType": 5126, "count": len(uv), "type": "VEC2"}, 34962)
            a["TEXCOORD_0"] = uv_of[a["POSITION"]]


def posed(path: Path, frame: int) -> dict[str, np.ndarray]:
    """World positions per mesh node name of glTF ``path`` at animation key ``frame``, as a
    player shows them: node TRS from the first animation, morph weights, then skinning."""
    from mimika.face.heads.gltf_scene import _Reader

    r = _Reader(Path(path))
    doc = r.src.doc
    anim = doc["animations"][0]
    local_trs: dict[int, dict] = {}
    weights: dict[int, np.ndarray] = {}
    for ch in anim["channels"]:
        s = anim["samplers"][ch["sampler"]]
        out = r.accessor(s["output"])
        n_keys = doc["accessors"][s["input"]]["count"]
        node, path_ = ch["target"]["node"], ch["target"]["path"]
        if path_ == "weights":
            weights[node] = out.reshape(n_keys, -1)[frame]
        else:
            local_trs.setdefault(node, {})[path_] = out[frame]
    nodes = doc["nodes"]
    world = _world(doc, np.stack([_local(nd, local_trs.get(i, {}).get("translation"),
                                         local_trs.get(i, {}).get("rotation"))
                                  if i in local_trs else _local(nd)
                                  for i, nd in enumerate(nodes)]))
    out: dict[str, np.ndarray] = {}
    for i, nd in enumerate(nodes):
        if "mesh" not in nd:
            continue
        mesh = doc["meshes"][nd["mesh"]]
        w = weights.get(i, np.asarray(mesh.get("weights", []), float))
        verts = []
        seen = set()
        for p in mesh["primitives"]:
            a = p["attributes"]
            if a["POSITION"] in seen:
                continue
            seen.add(a["POSITION"])
            v = r.accessor(a["POSITION"]).astype(float)
            for k, t in enumerate(p.get("targets", [])):
                if k < len(w) and w[k]:
                    v = v + w[k] * r.accessor(t["POSITION"])
            if "skin" in nd:
                sk = doc["skins"][nd["skin"]]
                ibm = r.accessor(sk["inverseBindMatrices"]).reshape(-1, 4, 4).transpose(0, 2, 1)
                mats = world[sk["joints"]] @ ibm
                jt = r.accessor(a["JOINTS_0"]).astype(int)
                wt = r.accessor(a["WEIGHTS_0"]).astype(float)
                m = np.einsum("nk,nkij->nij", wt / wt.sum(1, keepdims=True), mats[jt])
                v = np.einsum("nij,nj->ni", m[:, :3, :3], v) + m[:, :3, 3]
            else:
                v = v @ world[i, :3, :3].T + world[i, :3, 3]
            verts.append(v)
        out[nd["name"]] = np.concatenate(verts)
    return out

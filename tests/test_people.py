"""Random people (``mimika characters --random``): varied, valid, reproducible, whole faces,
and usable as batch heads by a pattern."""

from __future__ import annotations

import numpy as np
import pytest
from tests.conftest import needs_makehuman

from mimika.errors import DataError
from mimika.face.makehuman.character_file import character_from_dict
from mimika.face.makehuman.people import random_people, write_people


def test_the_same_seed_gives_the_same_people_and_another_seed_others():
    assert random_people(5, seed=3) == random_people(5, seed=3)
    assert random_people(5, seed=3) != random_people(5, seed=4)


def test_forty_people_vary_and_every_one_is_a_valid_character():
    people = [character_from_dict(d, d["name"]) for d in random_people(40, seed=1)]
    assert len({p.name for p in people}) == 40
    sexes = [p.phenotype["gender"] for p in people]
    assert 10 <= sum(sexes) <= 30  # both sexes, about half each
    ages = [p.phenotype["age"] for p in people]
    assert min(ages) < 30 and max(ages) > 65
    mains = {max(p.phenotype["origin"], key=p.phenotype["origin"].get) for p in people}
    assert mains == {"african", "asian", "caucasian"}
    assert len({p.hair for p in people}) >= 4 and len({p.clothes for p in people}) >= 4
    for p in people:
        assert len(p.modifiers) > 15  # a face of its own
        assert p.clothes[0].startswith("male_" if p.phenotype["gender"] else "female_")
        if p.hair == "afro01":
            assert "african" in p.phenotype["origin"]
    grey = [p.phenotype["age"] for p in people if p.hair_color == "#a39e98"]
    assert grey and min(grey) > 45


@needs_makehuman
def test_random_faces_differ_and_stay_whole():
    """Twelve random faces: landmarks millimetres apart from each other, and no triangle of
    the face turned over by the modifiers (each against its own unmodified build)."""
    from mimika.face.makehuman.base import first_copies, landmark_ids
    from mimika.face.makehuman.build import SCALE as CM
    from mimika.face.makehuman.build import Outfit, build

    def skin(c, mods):
        b = build(c.phenotype_values(), Outfit(None, None, None, ()), mods)
        return b.pieces[0]

    lms = []
    for d in random_people(12, seed=5):
        c = character_from_dict(d, d["name"])
        rest, face = skin(c, {}), skin(c, c.modifiers)
        ids = first_copies(face.weld, landmark_ids())
        lms.append(face.vertices[ids] * CM)
        tris = np.concatenate(list(face.parts.values()))
        near = tris[np.linalg.norm(face.vertices[tris].mean(1) * CM - lms[-1][30], axis=1) < 12]
        n0, n1 = (np.cross(v[near][:, 1] - v[near][:, 0], v[near][:, 2] - v[near][:, 0])
                  for v in (rest.vertices, face.vertices))
        cos = (n0 * n1).sum(1) / np.maximum(np.linalg.norm(n0, axis=1) *
                                             np.linalg.norm(n1, axis=1), 1e-12)
        assert (cos > 0).all(), f"{c.name}: {int((cos <= 0).sum())} face triangles flipped"
    lm = np.stack(lms)
    centred = lm - lm[:, 30:31]  # relative to the nose tip
    gaps = [np.abs(centred[i] - centred[j]).max() for i in range(12) for j in range(i)]
    assert min(gaps) > 0.3  # cm: no two faces alike


def test_written_people_are_never_overwritten(tmp_path):
    docs = random_people(3, seed=0)
    paths = write_people(docs, tmp_path / "people")
    assert [p.name for p in paths] == ["person01.yaml", "person02.yaml", "person03.yaml"]
    before = paths[0].read_bytes()
    with pytest.raises(DataError, match=r"person01\.yaml exists"):
        write_people(random_people(3, seed=9), tmp_path / "people")
    assert paths[0].read_bytes() == before


def test_characters_random_writes_files_a_user_can_load(tmp_path, capsys):
    from mimika.cli import main
    from mimika.face.makehuman.character_file import load_character_spec

    out = tmp_path / "cast"
    assert main(["characters", "--random", "4", "--seed", "2", "--out", str(out)]) == 0
    files = sorted(out.glob("*.yaml"))
    assert len(files) == 4 and "wrote" in capsys.readouterr().out
    c = load_character_spec(str(files[0]))
    assert c.name == "person01" and c.modifiers
    assert main(["characters", "--random", "4", "--out", str(out)]) == 2
    assert "exists" in capsys.readouterr().err

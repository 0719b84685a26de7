"""Hostile character files: one line saying what and where, exit code 2 (an alias bomb is
refused by its count, before it expands)."""

import pytest

from mimika.cli import main


def _bomb() -> str:
    rows = ["l0: &l0 [x, x, x, x, x, x, x, x, x]"]
    rows += [f"l{i}: &l{i} [" + ", ".join([f"*l{i - 1}"] * 9) + "]" for i in range(1, 9)]
    return "name: bomb\ndescription:\n  " + "\n  ".join(rows) + "\n"


@pytest.mark.parametrize(("text", "says"), [
    ("name: x\nphenotype:\n  age: 1" + "0" * 400 + "\n", "401-digit integer"),
    ("name: x\ndescription: " + "[" * 3000 + "]" * 3000 + "\n", "nested more than"),
    ("name: x\n1: 2\n", "keys must be text"),
    ("name: x\nphenotype:\n  age: !!int\n", "cannot read '' as !!int"),
    (_bomb(), "aliases"),
    ("name: x\nphenotype:\n  gender: .nan\n", "not a finite number"),
])
def test_hostile_character_file_is_one_clear_error(tmp_path, capsys, text, says):
    p = tmp_path / "c.yaml"
    p.write_text(text)
    assert main(["characters", "--show", str(p)]) == 2
    err = capsys.readouterr().err.strip()
    assert says in err and err.count("\n") == 0 and len(err) < 400, err
    assert "c.yaml" in err

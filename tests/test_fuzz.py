"""Fuzzing the readers (issues 20, 27): script, project, batch spec, expression library, every
CSV reader, character files and recordings get random and hostile input; each returns or raises a
MimikaError, within ``fuzzing.HANG_SECONDS``. This is the CI share (``FUZZ_EXAMPLES`` cases
per reader); the release run is ``make fuzz`` (bench/fuzz.py, ≥ 100 000 cases)."""

from __future__ import annotations

import os

import pytest
from hypothesis import HealthCheck, given, settings

from fuzzing import TARGETS, check, seeded

#: cases per reader in CI (FUZZ_EXAMPLES=… runs more)
FUZZ_EXAMPLES = int(os.environ.get("FUZZ_EXAMPLES", "60"))


@pytest.fixture(scope="module", autouse=True)
def _isolated(tmp_path_factory):
    old = os.environ.get("MIMIKA_DATA_DIR")
    os.environ["MIMIKA_DATA_DIR"] = str(tmp_path_factory.mktemp("fuzz-home"))
    yield
    if old is None:
        os.environ.pop("MIMIKA_DATA_DIR")
    else:
        os.environ["MIMIKA_DATA_DIR"] = old


@pytest.mark.parametrize("name", list(TARGETS))
def test_readers_never_crash_or_hang(name):
    gen, run = TARGETS[name]

    @settings(max_examples=FUZZ_EXAMPLES, deadline=None, database=None,
              suppress_health_check=list(HealthCheck))
    @given(seeded(gen))
    def fuzz(case):
        broke = check(run, case)
        assert broke is None, f"{name}: {broke}"

    fuzz()

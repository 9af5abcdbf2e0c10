"""The benchmarks stay runnable: the suite runs none of them (they take minutes and real
footage), so a name moved in the code would otherwise break ``python -m benchmarks`` unseen
(``exposed`` moved out of ``propagate.py`` broke the segmentation benchmark's import)."""

import importlib
import pkgutil

import pytest

import benchmarks

NAMES = sorted(m.name for m in pkgutil.iter_modules(benchmarks.__path__)
               if m.name.startswith("bench_"))


def test_the_benchmarks_are_found():
    assert "bench_segmentation" in NAMES and len(NAMES) >= 10


@pytest.mark.parametrize("name", NAMES)
def test_every_benchmark_imports_and_can_run(name):
    assert callable(importlib.import_module(f"benchmarks.{name}").run)

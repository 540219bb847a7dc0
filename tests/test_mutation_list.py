"""The planted bugs of `scripts/mutation_check.py` still plant something: each one's text is
found in its file exactly once (a stale entry plants nothing, and the check would report a
bug the suite no longer looks for as merely stale), each applied replacement changes the
file, and each names tests that exist."""

import importlib.util
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def _mutation_check():
    spec = importlib.util.spec_from_file_location("mutation_check",
                                                  ROOT / "scripts" / "mutation_check.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_every_planted_bug_is_found_once_and_changes_its_file():
    check = _mutation_check()
    stale = []
    for name, (path, replacements, tests) in check.MUTATIONS.items():
        text = (ROOT / path).read_text()
        planted, missing = check.plant(text, replacements)  # as the check plants it
        stale += [f"{name}: {old[:60]!r}" for old in missing]
        if planted == text or any(old == new for old, new in replacements):
            stale.append(f"{name}: a replacement changes nothing")
        for test in tests:
            file, _, function = test.partition("::")
            if not (ROOT / file).exists():
                stale.append(f"{name}: no test file {test}")
            elif function and f"def {function.split('[')[0]}(" not in (ROOT / file).read_text():
                stale.append(f"{name}: no test {test}")
    assert not stale, "\n".join(stale)

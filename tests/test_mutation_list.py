"""The planted bugs of `scripts/mutation_check.py` still plant something: each one's text is
found in its file exactly once (a stale entry plants nothing, and the check would report a
bug the suite no longer looks for as merely stale), each applied replacement changes the
file, and each names tests that exist."""

import importlib.util
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def _mutations():
    spec = importlib.util.spec_from_file_location("mutation_check",
                                                  ROOT / "scripts" / "mutation_check.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module.MUTATIONS


def test_every_planted_bug_is_found_once_and_changes_its_file():
    stale = []
    for name, (path, replacements, tests) in _mutations().items():
        text = (ROOT / path).read_text()
        for old, new in replacements:  # applied in order, as the check applies them
            if text.count(old) != 1 or old == new:
                stale.append(f"{name}: {old[:60]!r}")
            text = text.replace(old, new)
        for test in tests:
            if not (ROOT / test.split("::")[0]).exists():
                stale.append(f"{name}: no test file {test}")
            elif "::" in test:
                function = test.split("::")[1].split("[")[0]
                if f"def {function}(" not in (ROOT / test.split("::")[0]).read_text():
                    stale.append(f"{name}: no test {test}")
    assert not stale, "\n".join(stale)

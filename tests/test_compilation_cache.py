"""`use_compilation_cache`: the folder and thresholds it sets, and a folder it cannot create."""

import jax
import pytest

import vojax

SETTINGS = (
    "jax_compilation_cache_dir",
    "jax_persistent_cache_min_compile_time_secs",
    "jax_persistent_cache_min_entry_size_bytes",
)


@pytest.fixture
def restored():
    """The process's cache settings as they were (the tests' shared cache, tests/conftest.py)."""
    before = {name: getattr(jax.config, name) for name in SETTINGS}
    yield before
    for name, value in before.items():
        jax.config.update(name, value)


def test_the_folder_is_created_and_every_program_kept(tmp_path, restored):
    folder = tmp_path / "a" / "b"
    assert vojax.use_compilation_cache(folder) == str(folder)
    assert folder.is_dir()
    assert jax.config.jax_compilation_cache_dir == str(folder)
    # the small programs of a batch compile in ~0.1 s each: none is too small to keep
    assert jax.config.jax_persistent_cache_min_compile_time_secs == 0.0
    assert jax.config.jax_persistent_cache_min_entry_size_bytes == 0


def test_a_folder_that_cannot_be_made_changes_nothing(tmp_path, restored):
    blocker = tmp_path / "a file"
    blocker.write_text("not a folder")
    assert vojax.use_compilation_cache(blocker / "cache") is None
    assert {name: getattr(jax.config, name) for name in SETTINGS} == restored


def test_the_default_folder_follows_xdg_cache_home(tmp_path, monkeypatch, restored):
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    assert vojax.use_compilation_cache() == str(tmp_path / "vojax" / "xla")
    assert (tmp_path / "vojax" / "xla").is_dir()

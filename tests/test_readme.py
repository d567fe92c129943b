"""The README keeps its promises: the two set-up commands first, .ci/run running the
second, a front door under 200 lines whose Python example runs, whose counts match the
registry and whose links lead somewhere."""

import re
from pathlib import Path

from truthbench.effects import EFFECTS

ROOT = Path(__file__).resolve().parents[1]
README = (ROOT / "README.md").read_text()


def test_readme_opens_with_two_setup_commands_and_ci_runs_the_test_one():
    block = README.split("```bash\n", 1)[1].split("```", 1)[0].strip().splitlines()
    assert len(block) == 2
    assert "truthbench run campaigns/quickstart.toml" in block[0]
    assert block[1] in (ROOT / ".ci" / "run").read_text()


def test_readme_is_a_front_door():
    assert len(README.splitlines()) < 200


def test_readme_counts_match_the_registry():
    n_effects = int(re.search(r"effects registry \((\d+) effects\)", README).group(1))
    n_diagnosable = int(re.search(r"(\d+) diagnosable effects", README).group(1))
    assert n_effects == len(EFFECTS)
    assert n_diagnosable == sum(cls.diagnosis is not None for cls in EFFECTS.values())


def test_readme_links_lead_to_files():
    targets = re.findall(r"\]\(([^)#]+)(?:#[^)]*)?\)", README)
    local = [t for t in targets if not re.match(r"[a-z]+://", t)]
    assert local, "the README links into docs/"
    for target in local:
        assert (ROOT / target).exists(), target


def test_the_python_example_runs_and_uses_only_the_public_api(tmp_path, monkeypatch):
    """The README's Python example runs as written (one trial on one worker here, for
    time) and reaches only names of ``truthbench.__all__``."""
    import truthbench

    block = README.split("```python\nimport truthbench as tb\n", 1)[1].split("```", 1)[0]
    assert len(block.splitlines()) <= 20
    used = set(re.findall(r"\btb\.(\w+)", block))
    assert used <= set(truthbench.__all__), used - set(truthbench.__all__)
    assert "from truthbench." not in block
    monkeypatch.chdir(tmp_path)
    (tmp_path / "campaigns").mkdir()
    (tmp_path / "campaigns" / "quickstart.toml").write_text(
        (ROOT / "campaigns" / "quickstart.toml").read_text()
        .replace("record_s = 64.0", "record_s = 8.0"))
    code = "import truthbench as tb\n" + block.replace("trials=4, n_jobs=2", "trials=1, n_jobs=1")
    namespace = {}
    exec(compile(code, "README example", "exec"), namespace)
    assert namespace["H"].shape == (3, 1, 1)
    assert len(namespace["frfs"]) == 2

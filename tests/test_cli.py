"""The ``ngsgel`` command: every scene's ``--help`` (usage, a help and a default for each option)
and ``--quiet``."""

import re

import pytest

from ngsgel.cli import main
from ngsgel.scenes import SCENES

# options whose default says nothing (-h) or that the brief exempts (their defaults show anyway)
EXEMPT = {"-h", "--out", "--quick", "--quiet"}


def scene_help(name: str, capsys) -> str:
    with pytest.raises(SystemExit) as exit_:
        main(["run", name, "--help"])
    assert exit_.value.code == 0
    return capsys.readouterr().out


def option_entries(text: str) -> list[tuple[str, bool, str]]:
    """(option, takes a value, help text) of each option in a ``--help``'s options section."""
    section = text.split("\noptions:\n", 1)[1]
    entries: list[list[str]] = []
    for line in section.splitlines():
        if re.match(r"^  -", line):
            entries.append([line.strip()])
        elif line.startswith("   ") and entries:  # the help's continuation lines
            entries[-1].append(line.strip())
        elif line.strip():  # another section (argument groups): not expected in a scene's help
            raise AssertionError(f"unexpected line in the options section: {line!r}")
    result = []
    for first, *rest in entries:
        # argparse separates the invocation ("--rise RISE") from the help by two spaces or a new line
        invocation, _, help_start = first.partition("  ")
        option = invocation.split()[0].rstrip(",")
        result.append((option, " " in invocation, " ".join([help_start.strip(), *rest]).strip()))
    return result


@pytest.mark.parametrize("name", list(SCENES))
def test_scene_help_shows_usage_and_every_options_help_and_default(name, capsys):
    text = scene_help(name, capsys)
    assert text.startswith(f"usage: ngsgel run {name} "), text[:80]
    entries = option_entries(text)
    assert {"--out", "--quiet"} <= {option for option, _, _ in entries}
    for option, takes_value, help_text in entries:
        if option == "-h":
            continue
        meaning = re.sub(r"\(default: [^)]*\)", "", help_text).strip()
        assert meaning, f"{name} {option}: no help"
        if option not in EXEMPT and takes_value:
            assert "default" in help_text.lower(), f"{name} {option}: no default in {help_text!r}"
            assert help_text.lower().count("default:") <= 1, f"{name} {option}: default twice in {help_text!r}"
            # a default of None or "" stands for a rule, which the help must say
            assert not re.search(r"\(default: (None)?\)", help_text), f"{name} {option}: {help_text!r}"


def test_quiet_silences_a_scenes_progress(tmp_path, capsys):
    main(["run", "buckling-demo", "--quick", "--out", str(tmp_path / "loud")])
    loud = capsys.readouterr().err
    assert "[buckling_demo" in loud and "100% step" in loud
    main(["run", "buckling-demo", "--quick", "--quiet", "--out", str(tmp_path / "quiet")])
    assert capsys.readouterr().err == ""
    assert (tmp_path / "quiet" / "history.csv").read_text() == (tmp_path / "loud" / "history.csv").read_text()


def test_threads_option_holds_for_the_command_and_is_restored(monkeypatch):
    import threadpoolctl

    from ngsgel import cli
    from ngsgel.threads import configured_threads

    seen = []
    monkeypatch.setattr(cli, "list_scenes", lambda: seen.append(
        (configured_threads(), {info["num_threads"] for info in threadpoolctl.threadpool_info()
                                if info["user_api"] == "blas"})))
    before = configured_threads()
    assert before != 3
    assert main(["--threads", "3", "list"]) == 0
    assert seen == [(3, {1})]  # NGSolve on 3, every BLAS pool on one
    assert configured_threads() == before
    for bad in (["--threads", "0", "list"], ["--threads", "two", "list"], ["--threads"]):
        with pytest.raises(SystemExit):
            main(bad)

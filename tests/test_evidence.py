"""`millsim evidence`: the results pages computed with another engine than today's (issue 48)."""

import json

import millsim
from millsim.analysis import evidence
from millsim.cli import main

STALE_HASH = "0123456789ab"  # not today's: 12 hex digits no source tree hashes to by design


def pages(folder, today):
    folder.mkdir()
    (folder / "fresh.md").write_text(f"# Fresh\n\nMeasured today, engine {today}:\n\n| a |\n")
    (folder / "old.md").write_text(
        "# Old\n\n## Quick study\n\nMeasured 2026-11-21, engine\n"
        f"{STALE_HASH} (a hash on the line after the word)\n\n## Paper scale\n\n"
        f"with engine {today}; checksum deadbeef0123 of a file is no engine hash\n")
    (folder / "bare.md").write_text("# Bare\n\n1.5 W, no hash; commit 16a5317da64c alone\n")
    return folder


def test_evidence_lists_the_stale_page_with_its_section_and_counts_the_current(tmp_path, capsys):
    today = millsim.provenance_hash()
    folder = pages(tmp_path / "results", today)
    result = evidence.evidence(folder)
    status = {p["page"].rsplit("/", 1)[1]: p["status"] for p in result["pages"]}
    assert status == {"fresh.md": "current", "old.md": "stale", "bare.md": "no engine hash"}
    assert (result["total"], result["current"], result["stale"], result["no_hash"]) == (3, 1, 1, 1)
    old = next(p for p in result["pages"] if p["page"].endswith("old.md"))
    assert old["stale"] == [dict(line=6, section="Quick study", engine=STALE_HASH)]
    # the command: a count line first, then the pages that are not current
    assert main(["evidence", "--docs", str(folder), "--json", str(tmp_path / "e.json")]) == 0
    out = capsys.readouterr().out.splitlines()
    assert out[0] == (f"millsim evidence: 1 of 3 results pages current (engine {today}); "
                      "1 stale, 1 without an engine hash")
    assert any(line.startswith("STALE") and line.endswith("old.md") for line in out)
    assert f"line 6: engine {STALE_HASH}  (Quick study)" in "\n".join(out)
    assert not any(line.endswith("fresh.md") for line in out)
    assert json.loads((tmp_path / "e.json").read_text())["current"] == 1


def test_evidence_of_a_missing_folder_is_refused_in_one_line(tmp_path, capsys):
    assert main(["evidence", "--docs", str(tmp_path / "nowhere")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "nowhere" in err[0]


def test_a_second_hash_counts_within_60_characters_after_the_first():
    first, second = "aaaaaaaaaaaa", "bbbbbbbbbbbb"
    near = f"engine {first}" + "." * 59 + f" and {second}"  # 60 characters between them
    far = f"engine {first}" + "." * 60 + f" and {second}"
    assert [h for _, _, h in evidence.engine_hashes(near)] == [first, second]
    assert [h for _, _, h in evidence.engine_hashes(far)] == [first]


def test_the_word_engine_ending_the_line_before_reaches_back_60_characters():
    hexes = "cccccccccccc"
    within = "engine" + " " * 54 + "\n" + hexes  # "engine" starts the line's last 60 characters
    assert evidence.engine_hashes(within) == [(2, "", hexes)]
    assert evidence.engine_hashes("engine" + " " * 55 + "\n" + hexes) == []

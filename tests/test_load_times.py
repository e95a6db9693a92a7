"""The line under the README's time table on how much a busy machine stretches the quick runs
(lab.course.load_times, from benchmarks/chapter_load.csv that benchmarks/bench_chapter_load.py
writes): rendered from the file, left out without it, and a bad file refused by name and line.
No notebook runs here; the benchmark's own loop runs with a stand-in for papermill."""

import importlib.util
import subprocess
import sys
from pathlib import Path

import pytest
from helpers import subprocess_env

from lab.course.load_times import LOAD_COLUMNS, load_sentence, read_load_times, write_load_times
from lab.course.times import times_markdown, write_times_block
from lab.errors import InputError

ROOT = Path(__file__).resolve().parent.parent
HEADER = ",".join(LOAD_COLUMNS) + "\n"
ROWS = (
    '11_any_soft_body.ipynb,16.0,40.0,2.50,2,2026-01-03,"2 CPUs, Test CPU"\n'
    '03_learned_model.ipynb,14.0,28.0,2.00,2,2026-01-02,"2 CPUs, Test CPU"\n'
    '04_trajectory_following.ipynb,40.0,112.0,2.80,2,2026-01-02,"2 CPUs, Test CPU"\n'
)


def _course(d: Path) -> tuple[Path, Path]:
    (d / "nb").mkdir()
    (d / "nb" / "03_learned_model.ipynb").write_text("{}")
    (d / "times.csv").write_text("chapter,quick_s,full_s\n03_learned_model.ipynb,14.0,41.0\n")
    return d / "nb", d / "times.csv"


def test_the_line_says_the_median_range_chapters_and_file(tmp_path):
    (tmp_path / "load.csv").write_text(HEADER + ROWS)
    assert load_sentence(tmp_path / "load.csv") == (
        "Under load: with 2 other CPU-bound processes running beside it, a quick run took 2.5× as long as "
        "without them (median of chapters 03, 04 and 11; range 2.0–2.8×; 2026-01-02 to 2026-01-03, on 2 CPUs, "
        f"Test CPU; `{tmp_path / 'load.csv'}`, from `benchmarks/bench_chapter_load.py --load 2`)."
    )
    (tmp_path / "one.csv").write_text(HEADER + '11_a.ipynb,10.0,23.0,2.30,1,2026-01-02,"1 CPUs, X"\n')
    assert load_sentence(tmp_path / "one.csv").startswith(
        "Under load: with 1 other CPU-bound process running beside it, a quick run took 2.3× as long as without it "
        "(chapter 11; 2026-01-02, on 1 CPUs, X;"
    )


def test_the_line_goes_under_the_table_only_with_the_file(tmp_path):
    nb, times = _course(tmp_path)
    plain = times_markdown(nb, times)
    assert times_markdown(nb, times, tmp_path / "missing.csv") == plain  # measured or not said
    assert load_sentence(tmp_path / "missing.csv") == ""
    with pytest.raises(InputError, match="missing.csv: no such file"):
        load_sentence(tmp_path / "missing.csv", must_exist=True)
    (tmp_path / "load.csv").write_text(HEADER + ROWS)
    table = times_markdown(nb, times, tmp_path / "load.csv")
    assert table == plain + f"- {load_sentence(tmp_path / 'load.csv')}\n"
    # the README block takes it, and loses it again when the file goes
    readme = tmp_path / "README.md"
    readme.write_text("# Course\n\n<!-- chapter-times -->\n<!-- /chapter-times -->\n")
    assert write_times_block(readme, nb, times, tmp_path / "load.csv")
    assert "- Under load: with 2 other" in readme.read_text()
    (tmp_path / "load.csv").unlink()
    assert write_times_block(readme, nb, times, tmp_path / "load.csv")
    assert "Under load" not in readme.read_text() and "| `03_learned_model.ipynb` | 14 s | 41 s |" in readme.read_text()


def test_the_committed_file_reads_and_names_itself():
    path = ROOT / "benchmarks" / "chapter_load.csv"
    if not path.exists():
        pytest.skip("benchmarks/bench_chapter_load.py has not been run")
    rows = read_load_times(path)
    assert rows and all(r["chapter"].startswith(("03_", "04_", "11_")) for r in rows)
    assert "`benchmarks/chapter_load.csv`" in load_sentence(path)


BAD = [
    ("chapter,idle,loaded\n", "line 1: not a chapter-load CSV"),
    (HEADER, "no chapter measured"),
    (HEADER + "03_a.ipynb,1.0\n", "line 2: 2 fields where its header has 7"),
    (HEADER + ROWS.replace("16.0,", "-16.0,"), "line 2, column quick_idle_s: '-16.0' is not a finite number > 0"),
    (HEADER + ROWS.replace("28.0", "inf"), "line 3, column quick_loaded_s: 'inf' is not a finite number > 0"),
    (HEADER + ROWS.replace("2.80", "3.80"), "line 4, column ratio: '3.80' is not quick_loaded_s / quick_idle_s (2.80)"),
    (HEADER + ROWS.replace("2.50,2,", "2.50,0,"), "line 2, column load: '0' is not a count of CPU-bound processes"),
    (HEADER + ROWS.replace("2.50,2,", "2.50,1.5,"), "line 2, column load: '1.5' is not a count"),
    (HEADER + ROWS.replace("2.00,2,", "2.00,4,"), "line 3, column load: 4 where line 2 has 2"),
    (HEADER + ROWS.replace("2026-01-03", "yesterday"), "line 2, column date: 'yesterday' is not a date"),
    (HEADER + ROWS.replace('"2 CPUs, Test CPU"', '" "', 1), "line 2, column machine"),
    (HEADER + ROWS.replace("03_learned_model", "learned model"), "line 3, column chapter: 'learned model.ipynb'"),
    (HEADER + ROWS + ROWS.splitlines()[0] + "\n", "line 5: chapter 11_any_soft_body.ipynb has a row already"),
]


@pytest.mark.parametrize("text, words", BAD, ids=[w.split(":")[0] for _, w in BAD])
def test_a_bad_file_is_refused_by_name_and_line(tmp_path, text, words):
    path = tmp_path / "load.csv"
    path.write_text(text)
    with pytest.raises(InputError) as e:
        load_sentence(path)
    assert str(e.value).startswith(str(path)) and words in str(e.value), str(e.value)


def test_the_command_line_refuses_a_bad_file_with_exit_2(tmp_path):
    nb, times = _course(tmp_path)
    readme = tmp_path / "README.md"
    readme.write_text("# Course\n\n<!-- chapter-times -->\n<!-- /chapter-times -->\n")
    (tmp_path / "load.csv").write_text(HEADER + ROWS.replace("2.80", "3.80"))
    argv = ["chapter-times", "--notebooks", nb, "--times", times, "--load-times", tmp_path / "load.csv"]
    env = subprocess_env() | {"PYTHONPATH": str(ROOT)}  # this checkout's lab
    r = subprocess.run([sys.executable, "-m", "lab.course", *map(str, argv), "--write", str(readme)],
                       cwd=tmp_path, env=env, capture_output=True, text=True, timeout=60)  # fmt: skip
    assert r.returncode == 2, r.stderr
    assert f"error: {tmp_path / 'load.csv'}, line 4, column ratio" in r.stderr and "Traceback" not in r.stderr
    assert "<!-- chapter-times -->\n<!-- /chapter-times -->" in readme.read_text()  # not touched


def test_write_refuses_a_bad_row_and_keeps_the_file(tmp_path):
    path = tmp_path / "load.csv"
    path.write_text(HEADER + ROWS)
    row = dict(zip(LOAD_COLUMNS, ["03_a.ipynb", "10.0", "20.0", "2.00", 2, "2026-01-02", "2 CPUs, X"]))
    with pytest.raises(InputError, match=r"line 3, column ratio: '9.00'.*not written"):
        write_load_times(path, [row, row | {"chapter": "04_b.ipynb", "ratio": "9.00"}])
    assert path.read_text() == HEADER + ROWS
    write_load_times(path, [row])
    assert read_load_times(path) == [{c: str(v) for c, v in row.items()}]


def test_the_benchmark_alternates_and_writes_what_the_line_reads(tmp_path, monkeypatch):
    monkeypatch.syspath_prepend(str(ROOT / "benchmarks"))  # as when run as a script: its folder's helpers
    spec = importlib.util.spec_from_file_location("bench_chapter_load", ROOT / "benchmarks" / "bench_chapter_load.py")
    bench = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(bench)
    calls = []

    def fake_run(nb, load):  # papermill's wall time: 10 s alone, 25 s beside two
        calls.append((nb.name[:2], load))
        return (25.04 if load else 10.02), (float(load), 0.0, 0.0)

    monkeypatch.setattr(bench, "run_chapter", fake_run)
    out, csv_path = tmp_path / "bench.txt", tmp_path / "load.csv"
    argv = ["--load", "2", "--chapters", "03", "04", "11", "--out", str(out), "--csv", str(csv_path)]
    assert bench.main(argv) == 0
    assert calls == [("03", 0), ("03", 2), ("04", 2), ("04", 0), ("11", 0), ("11", 2)]
    rows = read_load_times(csv_path)
    assert [r["ratio"] for r in rows] == ["2.50"] * 3 and {r["load"] for r in rows} == {"2"}
    text = out.read_text()
    assert "command: python benchmarks/bench_chapter_load.py --load 2 --chapters 03 04 11" in text
    assert "ratio loaded/idle: median 2.50, range 2.50-2.50 over 3 chapter(s)" in text
    assert "2.5× as long" in load_sentence(csv_path)
    with pytest.raises(SystemExit):
        bench.main(["--chapters", "99", "--out", str(out), "--csv", str(csv_path)])

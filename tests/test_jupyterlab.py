"""A student's way in: the real JupyterLab server on loopback, a kernel it starts, chapter 01.

The server is started by ``scripts/jupyter`` itself (the README's command: .venv,
notebooks/ as the root, lab-venv the default kernel), on 127.0.0.1 with a token. One test
runs chapter 01's import cell in a kernel the server starts, through its REST and
websocket API, and checks that the kernel is this .venv's Python with the repository's
``lab`` and draws figures inline; the other loads the JupyterLab page with chapter 01 open
in headless Chromium and checks that the notebook's title is drawn. A third, without a
server, checks the "Notebook parameters" tables (docs/notebook-parameters.md) against the
parameters cells.
"""

import json
import os
import socket
import subprocess
import time
import urllib.request
import uuid
from pathlib import Path

import papermill
import pytest
from helpers import wait_until
from test_viz import CHROMIUM, CHROMIUM_FLAGS, require_chromium

ROOT = Path(__file__).resolve().parent.parent
CHAPTER = "01_fem_simulation.ipynb"
TOKEN = uuid.uuid4().hex
# test_viz's flags, but the page is served on loopback: resolve nothing else.
FLAGS = [f for f in CHROMIUM_FLAGS if not f.startswith(("--host-resolver-rules", "--virtual-time-budget"))] + [
    "--proxy-server=127.0.0.1:9",  # a closed port: any request off loopback fails
    "--proxy-bypass-list=127.0.0.1",
]


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@pytest.fixture(scope="module")
def server(tmp_path_factory):
    home = tmp_path_factory.mktemp("jupyter")
    port = _free_port()
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    env.update(
        JUPYTER_RUNTIME_DIR=str(home / "runtime"),
        JUPYTER_CONFIG_DIR=str(home / "config"),
        JUPYTERLAB_WORKSPACES_DIR=str(home / "workspaces"),
        OMP_NUM_THREADS="1",
        MKL_NUM_THREADS="1",
    )
    cmd = [
        "bash",
        str(ROOT / "scripts" / "jupyter"),  # adds --allow-root itself where it runs as root
        "--no-browser",
        f"--port={port}",
        "--ServerApp.ip=127.0.0.1",
        f"--IdentityProvider.token={TOKEN}",
        "--ServerApp.open_browser=False",
        "--LabServerApp.news_url=",
        "--LabApp.extension_manager=readonly",  # no package-index lookups
        "--LabApp.check_for_updates_class=jupyterlab.NeverCheckForUpdate",
    ]
    log = home / "server.log"  # a file, not a pipe: nobody reads the log while the tests run
    with log.open("w") as err:
        proc = subprocess.Popen(cmd, cwd=home, env=env, stdout=subprocess.DEVNULL, stderr=err)
    base = f"http://127.0.0.1:{port}"

    def up():
        if proc.poll() is not None:
            raise AssertionError(f"scripts/jupyter exited: {log.read_text()[-3000:]}")
        try:
            return urllib.request.urlopen(f"{base}/api/status?token={TOKEN}", timeout=2).status == 200
        except OSError:
            return False

    try:
        wait_until(up, 90, "the JupyterLab server")
        yield base
    finally:
        proc.terminate()
        try:
            proc.wait(timeout=20)
        except subprocess.TimeoutExpired:
            proc.kill()


def _api(base, path, method="GET", body=None):
    req = urllib.request.Request(
        f"{base}{path}?token={TOKEN}",
        method=method,
        data=None if body is None else json.dumps(body).encode(),
        headers={"Content-Type": "application/json"},
    )
    with urllib.request.urlopen(req, timeout=30) as r:
        return json.loads(r.read() or b"null")


def _first_cells(figures_dir) -> str:
    """Chapter 01's parameters cell and its import cell, as a student runs them first."""
    nb = json.loads((ROOT / "notebooks" / CHAPTER).read_text())
    code = ["".join(c["source"]) for c in nb["cells"] if c["cell_type"] == "code"]
    params = next(c for c in nb["cells"] if "parameters" in c.get("metadata", {}).get("tags", []))
    imports = next(c for c in code if "from lab" in c)
    return "".join(params["source"]) + f"\nfigures_dir = {str(figures_dir)!r}\n" + imports


def _execute(base, kernel_id, code, timeout=120, allow_stdin=False):
    """Run ``code`` in a kernel over the server's websocket (Jupyter messaging protocol):
    the execute_reply's content and everything the code printed. ``allow_stdin=True``
    executes as JupyterLab does (papermill and nbclient send False)."""
    import websocket  # websocket-client, a dependency of jupyter_server

    ws = websocket.create_connection(
        f"{base.replace('http', 'ws')}/api/kernels/{kernel_id}/channels?token={TOKEN}", timeout=timeout
    )
    msg_id = uuid.uuid4().hex
    header = {"msg_id": msg_id, "username": "test", "session": uuid.uuid4().hex, "version": "5.3", "date": ""}
    ws.send(
        json.dumps(
            {
                "header": {**header, "msg_type": "execute_request"},
                "parent_header": {},
                "metadata": {},
                "channel": "shell",
                "content": {
                    "code": code,
                    "silent": False,
                    "store_history": False,
                    "user_expressions": {},
                    "allow_stdin": allow_stdin,
                    "stop_on_error": True,
                },
            }
        )
    )
    reply, idle, printed, deadline = None, False, "", time.monotonic() + timeout
    try:
        # The reply (shell channel) can overtake the printed text (iopub): wait for both it
        # and the kernel's "idle" status, which follows the code's last output.
        while (reply is None or not idle) and time.monotonic() < deadline:
            msg = json.loads(ws.recv())
            if msg.get("parent_header", {}).get("msg_id") != msg_id:
                continue
            if msg["msg_type"] == "stream":
                printed += msg["content"]["text"]
            elif msg["msg_type"] == "error":
                raise AssertionError("\n".join(msg["content"]["traceback"]))
            elif msg["msg_type"] == "execute_reply":
                reply = msg["content"]
            elif msg["msg_type"] == "status":
                idle = msg["content"]["execution_state"] == "idle"
    finally:
        ws.close()
    assert reply is not None and reply["status"] == "ok", reply
    return reply, printed


WHERE = "import lab, sys, matplotlib\nprint('LAB-FROM', lab.__file__, sys.executable, matplotlib.get_backend())"


def _check_where(printed):
    lab_file, python, backend = printed.split("LAB-FROM", 1)[1].split()[:3]
    assert Path(lab_file).is_relative_to(ROOT / "lab")  # the repository's lab, editable
    assert Path(python).resolve() == (ROOT / ".venv" / "bin" / "python").resolve()  # the .venv's Python
    assert "inline" in backend, f"figures would not be drawn in the notebook: backend {backend}"


def test_chapter_01_imports_run_in_a_kernel_the_server_started(server, tmp_path):
    specs = _api(server, "/api/kernelspecs")
    assert specs["default"] == "lab-venv" and "lab-venv" in specs["kernelspecs"], specs["default"]
    # The kernel chapter 01 asks for in its metadata (what JupyterLab starts on opening it).
    name = json.loads((ROOT / "notebooks" / CHAPTER).read_text())["metadata"]["kernelspec"]["name"]
    kernel = _api(server, "/api/kernels", "POST", {"name": name, "path": CHAPTER})
    try:
        _, printed = _execute(server, kernel["id"], _first_cells(tmp_path) + "\n" + WHERE)
        _check_where(printed)
    finally:
        _api(server, f"/api/kernels/{kernel['id']}", "DELETE")
    # A new notebook's kernel: the server's default, lab-venv.
    kernel = _api(server, "/api/kernels", "POST", {})
    try:
        assert kernel["name"] == "lab-venv"
        _check_where(_execute(server, kernel["id"], WHERE)[1])
    finally:
        _api(server, f"/api/kernels/{kernel['id']}", "DELETE")


@pytest.mark.browser
def test_jupyterlab_page_draws_chapter_01(server, tmp_path):
    require_chromium()
    title = json.loads((ROOT / "notebooks" / CHAPTER).read_text())["cells"][0]["source"][0].lstrip("# ").strip()
    profile = tmp_path / "profile"
    profile.mkdir()
    run = subprocess.run(
        [
            str(CHROMIUM),
            *FLAGS,
            f"--user-data-dir={profile}",
            "--virtual-time-budget=30000",
            "--dump-dom",
            f"{server}/lab/tree/{CHAPTER}?token={TOKEN}",
        ],
        capture_output=True,
        text=True,
        timeout=180,
    )
    assert run.returncode == 0, run.stderr[-3000:]
    assert "jp-Notebook" in run.stdout, f"JupyterLab did not open the notebook: {run.args} {run.stderr[-500:]}"
    assert title.split("—")[0].strip() in run.stdout and "finite-element" in run.stdout, "title cell not drawn"


def test_docs_document_every_notebook_parameter():
    """docs/notebook-parameters.md: one table per chapter, a row per parameter of its
    parameters cell (papermill's reading of it) with the same default."""
    import re

    doc = "docs/notebook-parameters.md"
    section = (ROOT / doc).read_text()
    problems = []
    for nb in sorted((ROOT / "notebooks").glob("[0-9][0-9]_*.ipynb")):
        if f"**`{nb.name}`**" not in section:
            problems.append(f"{nb.name}: no table")
            continue
        table = section.split(f"**`{nb.name}`**", 1)[1].split("**`", 1)[0]
        rows = dict(re.findall(r"^\| `(\w+)` \| `(.*?)` \|", table, re.M))
        params = papermill.inspect_notebook(str(nb))
        for name, p in params.items():
            if name not in rows:
                problems.append(f"{nb.name}: {name} (default {p['default']}) is not in {doc}")
            elif rows[name] != p["default"]:
                problems.append(f"{nb.name}: {name} default {p['default']}, {doc} says {rows[name]}")
        extra = rows.keys() - params
        problems += [f"{nb.name}: {doc} lists {name}, the notebook has no such parameter" for name in extra]
    assert not problems, "\n".join(problems)

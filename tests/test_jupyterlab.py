"""A student's way in: the real JupyterLab server on loopback, a kernel it starts, chapter 01.

The server is the one ``scripts/jupyter`` starts (``python -m jupyterlab`` of this
environment, notebooks/ as its root), on 127.0.0.1 with a token. One test runs chapter
01's import cell in a kernel the server starts, through its REST and websocket API; the
other loads the JupyterLab page with chapter 01 open in headless Chromium and checks that
the notebook's title is drawn.
"""

import json
import os
import socket
import subprocess
import sys
import time
import urllib.request
import uuid
from pathlib import Path

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
        sys.executable,
        "-m",
        "jupyterlab",
        "--no-browser",
        f"--port={port}",
        "--ServerApp.ip=127.0.0.1",
        f"--IdentityProvider.token={TOKEN}",
        f"--ServerApp.root_dir={ROOT / 'notebooks'}",
        "--ServerApp.open_browser=False",
        "--LabServerApp.news_url=",
        "--LabApp.extension_manager=readonly",  # no package-index lookups
        "--LabApp.check_for_updates_class=jupyterlab.NeverCheckForUpdate",
    ]
    if hasattr(os, "geteuid") and os.geteuid() == 0:
        cmd.append("--allow-root")  # containers and CI run as root
    proc = subprocess.Popen(cmd, cwd=home, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    base = f"http://127.0.0.1:{port}"

    def up():
        if proc.poll() is not None:
            raise AssertionError(f"jupyterlab exited: {proc.stderr.read()[-3000:]}")
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


@pytest.mark.slow
def test_chapter_01_imports_run_in_a_kernel_the_server_started(server, tmp_path):
    import websocket

    kernel = _api(server, "/api/kernels", "POST", {"name": "python3", "path": CHAPTER})
    try:
        ws = websocket.create_connection(
            f"{server.replace('http', 'ws')}/api/kernels/{kernel['id']}/channels?token={TOKEN}", timeout=120
        )
        code = _first_cells(tmp_path) + "\nimport lab, sys\nprint('LAB-FROM', lab.__file__, sys.executable)"
        msg_id = uuid.uuid4().hex
        ws.send(
            json.dumps(
                {
                    "header": {
                        "msg_id": msg_id,
                        "username": "test",
                        "session": uuid.uuid4().hex,
                        "msg_type": "execute_request",
                        "version": "5.3",
                        "date": "",
                    },
                    "parent_header": {},
                    "metadata": {},
                    "channel": "shell",
                    "content": {
                        "code": code,
                        "silent": False,
                        "store_history": False,
                        "user_expressions": {},
                        "allow_stdin": False,
                        "stop_on_error": True,
                    },
                }
            )
        )
        reply, printed, deadline = None, "", time.monotonic() + 120
        while reply is None and time.monotonic() < deadline:
            msg = json.loads(ws.recv())
            if msg.get("parent_header", {}).get("msg_id") != msg_id:
                continue
            if msg["msg_type"] == "stream":
                printed += msg["content"]["text"]
            elif msg["msg_type"] == "error":
                raise AssertionError("\n".join(msg["content"]["traceback"]))
            elif msg["msg_type"] == "execute_reply":
                reply = msg["content"]
        ws.close()
        assert reply is not None and reply["status"] == "ok", reply
        where = printed.split("LAB-FROM", 1)[1].split()
        assert Path(where[0]).is_relative_to(ROOT / "lab")  # the repository's lab, editable
        assert Path(where[1]).resolve() == Path(sys.executable).resolve()  # this environment's Python
    finally:
        _api(server, f"/api/kernels/{kernel['id']}", "DELETE")


@pytest.mark.slow
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

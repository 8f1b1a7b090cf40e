"""The workspace builds with colcon as on a full ROS 2 install, and the ament index finds
what ``ros2 run`` / ``ros2 launch`` / ``ros2 interface`` look up.

colcon comes from PyPI (requirements-colcon.txt, installed by scripts/setup.sh).  The
build goes to a temporary folder (``colcon build --base-paths msg_defs .`` with its
build, install and log bases there); the checks run in a fresh process whose environment
is the install's ``local_setup.sh`` over the venv (the underlay that holds Jazzy).
About a minute, most of it the interface package's C/C++ build.
"""
from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

pytest.importorskip("rclpy", reason="ROS 2 wheels not installed: run scripts/setup.sh")

from tethernet_ros.ros.names import NODES  # noqa: E402

pytestmark = [pytest.mark.ros, pytest.mark.timeout(900)]

ROOT = Path(__file__).resolve().parent.parent
VENV = Path(sys.prefix)
COLCON = VENV / "bin" / "colcon"

# run inside the workspace's environment; prints what the ament index says, as JSON
PROBE = r"""
import json, os
from ament_index_python.packages import get_package_prefix, get_package_share_directory
from ament_index_python.resources import get_resource
import tethernet_msgs.msg, tethernet_ros
from tethernet_msgs.msg import NoiseSettings
from tethernet_msgs.action import Capture
prefix = get_package_prefix("tethernet_ros")
exe_dir = os.path.join(prefix, "lib", "tethernet_ros")
interfaces, msgs_prefix = get_resource("rosidl_interfaces", "tethernet_msgs")
print(json.dumps({
    "tethernet_ros": prefix,
    "tethernet_msgs": get_package_prefix("tethernet_msgs"),
    "executables": sorted(f for f in os.listdir(exe_dir)
                          if os.access(os.path.join(exe_dir, f), os.X_OK)),
    "exe_dir": exe_dir,
    "interfaces": sorted(interfaces.split()),
    "share": get_package_share_directory("tethernet_ros"),
    "msgs_module": tethernet_msgs.msg.__file__,
    "ros_module": tethernet_ros.__file__,
    "noise_default": NoiseSettings().speed_scale,
    "canceled": Capture.Result.CANCELED,
}))
"""


@pytest.fixture(scope="module")
def workspace(tmp_path_factory):
    if not COLCON.is_file():
        pytest.skip("colcon is not installed in the venv: run scripts/setup.sh")
    ws = tmp_path_factory.mktemp("colcon_ws")
    env = dict(os.environ)
    env.update(PATH=f"{VENV / 'bin'}{os.pathsep}{env.get('PATH', '')}",
               AMENT_PREFIX_PATH=str(VENV), CMAKE_PREFIX_PATH=str(VENV))
    env.pop("PYTHONPATH", None)
    out = subprocess.run(
        [str(COLCON), "--log-base", str(ws / "log"), "build", "--base-paths", "msg_defs", ".",
         "--build-base", str(ws / "build"), "--install-base", str(ws / "install"),
         "--cmake-args", f"-DPython3_EXECUTABLE={VENV / 'bin' / 'python'}",
         "-DBUILD_TESTING=OFF"],
        cwd=ROOT, env=env, capture_output=True, text=True, timeout=840)
    assert out.returncode == 0, (out.stdout + out.stderr)[-4000:]
    for package in ("tethernet_msgs", "tethernet_ros"):
        assert f"Finished <<< {package}" in out.stdout, out.stdout[-2000:]
    return ws, env


def in_workspace(ws: Path, env: dict, command: str) -> subprocess.CompletedProcess:
    """Run ``command`` in sh after sourcing the install's local_setup.sh."""
    return subprocess.run(["sh", "-c", f'. "{ws / "install" / "local_setup.sh"}" && {command}'],
                          env=env, capture_output=True, text=True, timeout=120, cwd=ws)


def test_ament_index_finds_nodes_and_interfaces(workspace):
    ws, env = workspace
    out = in_workspace(ws, env, f'"{sys.executable}" -c \'{PROBE}\'')
    assert out.returncode == 0, out.stderr[-3000:]
    found = json.loads(out.stdout.strip().splitlines()[-1])
    install = ws / "install"
    assert Path(found["tethernet_ros"]) == install / "tethernet_ros"
    assert Path(found["tethernet_msgs"]) == install / "tethernet_msgs"
    # `ros2 run tethernet_ros <node>` runs <prefix>/lib/tethernet_ros/<node>
    assert set(NODES) <= set(found["executables"])
    # `ros2 interface list` / `show` read the rosidl_interfaces resource
    for name in ("CaptureMetrics", "ClosingCommand", "Design", "EpisodeResult", "EpisodeSetup",
                 "LaunchCommand", "NetState", "NoiseSettings"):
        assert f"msg/{name}.msg" in found["interfaces"], name
    assert "srv/RunCapture.srv" in found["interfaces"]
    assert "action/Capture.action" in found["interfaces"]     # `ros2 action` / `interface`
    # `ros2 launch tethernet_ros tethernet.launch.py` and its parameter file
    share = Path(found["share"])
    assert (share / "launch" / "tethernet.launch.py").is_file()
    assert (share / "config" / "tethernet.yaml").is_file()
    assert (share / "package.xml").is_file()
    # Python finds the workspace's packages before the venv's
    assert found["msgs_module"].startswith(str(install / "tethernet_msgs"))
    assert found["ros_module"].startswith(str(install / "tethernet_ros"))
    assert found["noise_default"] == 1.0
    assert found["canceled"] == 4


def test_installed_executables_run(workspace):
    ws, env = workspace
    exe = ws / "install" / "tethernet_ros" / "lib" / "tethernet_ros"
    out = in_workspace(ws, env, f'"{exe / "tethernet"}" --help')
    assert out.returncode == 0, out.stderr[-2000:]
    assert "capture" in out.stdout and "replay" in out.stdout

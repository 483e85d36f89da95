"""An option that does not apply to the backend chosen is refused, one line and exit 2, never
ignored (issue 28, item 6: ``dronefleet drone --fc mavlink --plume ...`` flew with no gas sensor
and said nothing). Given with its default value too: the operator meant something by it."""

from __future__ import annotations

import subprocess

import pytest

from support.processes import dronefleet

pytestmark = pytest.mark.integration

MAVLINK = ("--fc", "mavlink", "--fc-url", "udpout:127.0.0.1:9")
UAVTALK = ("--fc", "uavtalk", "--fc-url", "tcp:127.0.0.1:9")
SIM = ("--fc", "sim")


def refusal(*args: str) -> str:
    done = subprocess.run(dronefleet(*args), capture_output=True, text=True, timeout=60)
    assert done.returncode == 2, (done.returncode, done.stderr)
    assert "Traceback" not in done.stderr
    (line,) = done.stderr.splitlines()  # no usage either: argparse accepted every value
    return line


@pytest.mark.parametrize(
    ("backend", "option", "only"),
    [
        (SIM, ("--fc-url", "udpout:127.0.0.1:9"), "--fc mavlink or uavtalk only"),
        (SIM, ("--mavlink-signing-key-file", "key"), "--fc mavlink only"),
        (UAVTALK, ("--mavlink-signing-key-file", "key"), "--fc mavlink only"),
        (SIM, ("--onboard-missions",), "--fc mavlink only"),
        (UAVTALK, ("--onboard-missions",), "--fc mavlink only"),
        (SIM, ("--set-autopilot-failsafe",), "--fc mavlink only"),
        (SIM, ("--no-set-autopilot-failsafe",), "--fc mavlink only"),
        (UAVTALK, ("--no-set-autopilot-failsafe",), "--fc mavlink only"),
        (MAVLINK, ("--home", "40.63,-8.659,10"), "--fc sim only"),
        (UAVTALK, ("--home", "40.63,-8.659,10"), "--fc sim only"),
        (MAVLINK, ("--speedup", "1"), "--fc sim only"),  # its default, given all the same
        (UAVTALK, ("--speedup", "5"), "--fc sim only"),
        (MAVLINK, ("--battery-pct", "50"), "--fc sim only"),
        (UAVTALK, ("--battery-pct", "50"), "--fc sim only"),
        (MAVLINK, ("--wind", "8@270"), "--fc sim only"),
        (UAVTALK, ("--wind", "8@270"), "--fc sim only"),
    ],
    ids=lambda v: " ".join(v) if isinstance(v, tuple) else v,
)
def test_a_drone_option_for_another_backend_is_one_line_and_exit_2(backend, option, only):
    line = refusal("drone", "--id", "QUAD_1", *backend, *option)
    fc = backend[1]
    assert line.startswith(f"dronefleet drone: not for --fc {fc}: {option[0]} is for {only} ("), (
        line
    )


def test_every_wrong_option_is_named_on_the_one_line():
    line = refusal("drone", *MAVLINK, "--speedup", "5", "--plume", "40.63,-8.659,900,10",
                   "--home", "40.63,-8.659,10", "--onboard-missions")  # fmt: skip
    assert "--speedup is for --fc sim only" in line and "--home is for --fc sim only" in line
    assert "--plume" not in line and "--onboard-missions" not in line  # both apply to mavlink


@pytest.mark.parametrize(
    ("args", "option", "only"),
    [
        (("--uavtalk", "tcp:127.0.0.1:9", "--plume", "40.63,-8.659,900,10"), "--plume", "mavlink"),
        (("--uavtalk", "tcp:127.0.0.1:9", "--sysid-base", "3"), "--sysid-base", "mavlink"),
        (("--uavtalk", "tcp:127.0.0.1:9", "--pictures", "pics"), "--pictures", "mavlink"),
        (
            ("--uavtalk", "tcp:127.0.0.1:9", "--mavlink", "udp:127.0.0.1:14550"),
            "--mavlink",
            "mavlink",
        ),
        (
            ("--uavtalk", "tcp:127.0.0.1:9", "--mavlink-signing-key-file", "key"),
            "--mavlink-signing-key-file",
            "mavlink",
        ),
        (("--id-prefix", "QUAD"), "--id-prefix", "uavtalk"),
    ],
    ids=lambda v: " ".join(v) if isinstance(v, tuple) else v,
)
def test_a_sim_option_for_the_other_protocol_is_one_line_and_exit_2(args, option, only):
    line = refusal("sim", *args)
    assert line.startswith("dronefleet sim: not when serving "), line
    assert f"{option} is for {only} only (" in line, line


def test_a_bad_plume_is_refused_by_argparse():
    done = subprocess.run(
        dronefleet("drone", *MAVLINK, "--plume", "40.63,-8.659,900,0"),
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert done.returncode == 2 and "Traceback" not in done.stderr
    assert "RADIUS_M positive" in done.stderr.splitlines()[-1]

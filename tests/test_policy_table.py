"""The one table of policies (core/kernel/policy_table.py; docs/model.md §14, §16): the
kernel's indices, the configurations, the command line, the ROS loop and the studies all
read it, and each row names settings its role's configuration has."""
from __future__ import annotations

import dataclasses

import pytest

from tethernet_ros.commands.common import CLI_LAUNCH_POLICIES, CLI_POLICIES
from tethernet_ros.core import kernel as kn
from tethernet_ros.core.config import SimConfig
from tethernet_ros.core.kernel import policy as kpolicy
from tethernet_ros.core.kernel.policy_table import (CONTROLLER, KERNEL, NONE, POLICY_TABLE,
                                                    ROLES, choices_help, controller_policy,
                                                    policies, policy_index, selectable, spec)
from tethernet_ros.core.launch import LaunchConfig, LaunchError
from tethernet_ros.core.policies import PolicyConfig, PolicyError
from tethernet_ros.ros.loop import in_lockstep, kernel_config
from tethernet_ros.studies.cells import CLOSING_POLICIES, LAUNCHES

CONFIGS = {"closing": (PolicyConfig, PolicyError), "launch": (LaunchConfig, LaunchError)}


def test_rows_are_unique_and_well_formed():
    keys = [(p.role, p.name) for p in POLICY_TABLE]
    assert len(keys) == len(set(keys))
    for p in POLICY_TABLE:
        assert p.role in ROLES and p.decider in (KERNEL, CONTROLLER, NONE), p
        assert p.summary and isinstance(p.settings, tuple) and isinstance(p.memory, tuple)
        fields = {f.name for f in dataclasses.fields(CONFIGS[p.role][0])} - {"kind"}
        assert set(p.settings) <= fields, (p.name, set(p.settings) - fields)
    for role in ROLES:                         # one controller's policy per role
        assert spec(role, controller_policy(role)).decider == CONTROLLER


def test_the_kernel_indices_are_the_table_order():
    assert kn.LAUNCH_POLICIES == policies("launch")
    assert kpolicy.POLICIES == policies("closing")
    for role, pairs in (("closing", {"threshold": kpolicy.POLICY_THRESHOLD,
                                     "adaptive": kpolicy.POLICY_ADAPTIVE,
                                     "external": kpolicy.POLICY_EXTERNAL}),
                        ("launch", {"immediate": kn.LAUNCH_IMMEDIATE,
                                    "predictive": kn.LAUNCH_PREDICTIVE,
                                    "external": kn.LAUNCH_EXTERNAL})):
        assert {n: policy_index(role, n) for n in pairs} == pairs
        cls, _ = CONFIGS[role]
        for name in policies(role):
            assert cls(kind=name).index == policy_index(role, name)


@pytest.mark.parametrize("role", ROLES)
def test_configurations_and_flags_accept_what_the_table_lists(role):
    cls, error = CONFIGS[role]
    for name in policies(role):
        cls(kind=name)
    with pytest.raises(error, match=f"field 'kind'.*{', '.join(policies(role))}"):
        cls(kind="no-such-policy")
    flags = {"closing": CLI_POLICIES, "launch": CLI_LAUNCH_POLICIES}[role]
    assert flags == selectable(role) and controller_policy(role) not in flags
    for name in flags:
        assert f"{name}: {spec(role, name).summary}" in choices_help(role)
    with pytest.raises(KeyError, match="no-such-policy"):
        spec(role, "no-such-policy")


def test_the_launch_kinds_and_the_loop_follow_the_deciders():
    for name in policies("launch"):
        cfg = LaunchConfig(kind=name)
        assert cfg.immediate == (spec("launch", name).decider == NONE)
        assert cfg.built_in == (spec("launch", name).decider == KERNEL)
        sim = SimConfig(launch=cfg)
        assert in_lockstep(False, sim) == (spec("launch", name).decider == CONTROLLER)
        # a lockstep episode's kernel leaves every decision the project would take to ROS
        out = kernel_config(sim)
        assert out.policy.kind == controller_policy("closing")
        assert out.launch.kind == (controller_policy("launch") if cfg.built_in else name)


def test_studies_compare_the_policies_the_table_lists():
    assert CLOSING_POLICIES == policies("closing", KERNEL)
    assert LAUNCHES == selectable("launch")

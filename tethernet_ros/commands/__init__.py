"""Subcommands of the `tethernet` CLI (see tethernet_ros.cli)."""

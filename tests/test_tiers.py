"""The test suite's own set-up: the groups that keep each expensive fixture on one worker."""

import os

import pytest


def test_the_workers_are_sent_whole_groups(request):
    """Under ``pytest -n 2`` (the README's test command) a test's node id carries its
    ``xdist_group``, which is how pytest-xdist's ``--dist loadgroup`` sends a group to one
    worker; without it every expensive session fixture is made on both workers."""
    if "PYTEST_XDIST_WORKER" not in os.environ:
        pytest.skip("not run by pytest-xdist")
    assert request.node.nodeid.endswith("@test_tiers.py"), request.node.nodeid

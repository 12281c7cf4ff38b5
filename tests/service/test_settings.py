"""Settings from the environment, CLI flags over them, configuration errors exit with 2."""
from __future__ import annotations

import argparse

import pytest

from impactnet.service import cli
from impactnet.service.settings import Settings


def _args(*argv: str) -> argparse.Namespace:
    parser = argparse.ArgumentParser()
    cli.add_arguments(parser)
    return parser.parse_args(list(argv))


def test_safe_defaults():
    s = Settings(_env_file=None)
    assert s.host == "127.0.0.1" and s.port == 8000 and s.scene == "quay_crane"
    assert s.admin_token is None and s.bundle is None and s.default_mode is None
    assert s.max_body_bytes == 64 * 1024 * 1024 and s.max_batch_pairs == 100_000
    assert s.max_json_body_bytes == 32 * 1024 * 1024 and s.max_pair_body_bytes == 64 * 1024
    assert s.body_timeout_s == 10.0 and s.memory_budget_bytes == 512 * 1024 * 1024
    assert s.drain_delay_s == 1.0  # readiness 503 before the socket closes (issue 23)


def test_environment_and_flags(monkeypatch):
    monkeypatch.setenv("IMPACTNET_PORT", "9001")
    monkeypatch.setenv("IMPACTNET_MAX_BATCH_PAIRS", "50")
    monkeypatch.setenv("IMPACTNET_ADMIN_TOKEN", "s3cret")
    s = cli.settings_from(_args("--max-batch-pairs", "70", "--no-access-log"))
    assert s.port == 9001 and s.max_batch_pairs == 70 and s.access_log is False
    assert s.admin_token.get_secret_value() == "s3cret" and "s3cret" not in repr(s)


@pytest.mark.parametrize("argv,message", [
    (("--scene", "no_such_scene"), "no_such_scene"),
    (("--bundle", "some/bundle"), "some/bundle"),
    (("--max-batch-pairs", "0"), "invalid setting"),
    (("--default-mode", "fastest"), "invalid setting"),
])
def test_configuration_errors_exit_2(capsys, argv, message):
    assert cli.run(_args(*argv)) == cli.EXIT_CONFIG
    assert message in capsys.readouterr().err

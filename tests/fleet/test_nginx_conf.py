"""The front's one template (docker/nginx.conf) renders for both of its users: the compose file
(nginx 1.27, envsubst in the image's entrypoint, replicas re-resolved by name) and a loopback
fleet (Debian's nginx 1.22, which has no ``resolve``: one server line per replica port)."""
from __future__ import annotations

import os
import re
import shutil
import subprocess
from pathlib import Path

import pytest
import yaml

from impactnet.service.fleet import nginx_conf
from tests.fleet.helpers import nginx_test, nginx_version

REPO = Path(__file__).resolve().parents[2]
COMPOSE = REPO / "docker" / "compose.yaml"
#: First nginx release whose open-source build has the upstream server's `resolve` parameter.
RESOLVE_SINCE = (1, 27, 3)


def compose_front() -> dict:
    return yaml.safe_load(COMPOSE.read_text())["services"]["front"]


def compose_rendering() -> str:
    """What the nginx image's entrypoint (20-envsubst-on-templates.sh) makes of the template
    with the compose file's environment: envsubst restricted to the defined variables that
    match NGINX_ENVSUBST_FILTER. Runs the real envsubst where it is installed."""
    env = compose_front()["environment"]
    pattern = re.compile(env["NGINX_ENVSUBST_FILTER"])
    defined = {k: str(v) for k, v in env.items() if pattern.search(k)}
    template = nginx_conf.TEMPLATE.read_text()
    if shutil.which("envsubst") is None:
        return nginx_conf.render(defined, template)
    names = " ".join(f"${{{k}}}" for k in defined)
    return subprocess.run(["envsubst", names], input=template, capture_output=True, text=True,
                          env={"PATH": os.environ["PATH"], **defined}, check=True).stdout


def test_compose_mounts_the_template_where_the_entrypoint_renders_it_for_nginx():
    front = compose_front()
    env = front["environment"]
    assert f"./nginx.conf:{env['NGINX_ENVSUBST_TEMPLATE_DIR']}/nginx.conf.template:ro" in \
        front["volumes"]
    rendered = f"{env['NGINX_ENVSUBST_OUTPUT_DIR']}/nginx.conf"
    assert front["command"][:3] == ["nginx", "-c", rendered]
    assert rendered.startswith(tuple(f"{t}/" for t in front["tmpfs"]))  # root fs read-only


def test_the_compose_rendering_fills_every_placeholder_and_keeps_nginx_variables():
    text = compose_rendering()
    assert "${" not in text
    assert "server impactnet:8000 resolve max_fails=0;" in text
    assert "resolver 127.0.0.11" in text and "listen 8080;" in text
    assert "$request_id" in text  # nginx's own variable, not the environment's
    # the Python renderer gives the same text for the same values
    env = compose_front()["environment"]
    assert nginx_conf.render({k: env[k] for k in nginx_conf.PLACEHOLDERS}) == text


def test_the_loopback_rendering_has_one_server_per_replica_and_no_resolve():
    values = nginx_conf.loopback_values(["127.0.0.1:8001", "127.0.0.1:8002"], "127.0.0.1:9000",
                                        "/tmp/front")
    text = nginx_conf.render(values)
    assert "${" not in text and not re.search(r"^\s*(server|resolver) .*resolve", text, re.M)
    assert re.findall(r"server (127\.0\.0\.1:\d+) max_fails=0;", text) == \
        ["127.0.0.1:8001", "127.0.0.1:8002"]
    assert "listen 127.0.0.1:9000;" in text and "pid /tmp/front/nginx.pid;" in text


def test_a_missing_value_is_refused_not_left_in_the_config():
    with pytest.raises(nginx_conf.TemplateError, match="NGINX_UPSTREAM_SERVERS"):
        nginx_conf.render({"NGINX_LISTEN": "1", "NGINX_RUN_DIR": "/tmp", "NGINX_RESOLVER": ""})


@pytest.mark.slow
def test_nginx_accepts_the_loopback_rendering(nginx, tmp_path):
    tmp_path.chmod(0o755)
    values = nginx_conf.loopback_values(["127.0.0.1:8001", "127.0.0.1:8002", "127.0.0.1:8003"],
                                        "127.0.0.1:9000", str(tmp_path))
    done = nginx_test(nginx, nginx_conf.render(values), str(tmp_path))
    assert done.returncode == 0, done.stderr


@pytest.mark.slow
def test_nginx_accepts_the_compose_rendering(nginx, tmp_path):
    """The compose rendering as it is where this nginx has ``resolve`` (1.27.3+). On an older
    one (Debian 12: 1.22) everything but the upstream server line is checked as rendered: that
    line is the only one that must differ, and it names a host that resolves only in compose."""
    tmp_path.chmod(0o755)
    text = compose_rendering().replace("/tmp", str(tmp_path))
    if nginx_version(nginx) < RESOLVE_SINCE:
        done = nginx_test(nginx, text, str(tmp_path))
        assert done.returncode != 0 and 'invalid parameter "resolve"' in done.stderr
        text = text.replace("server impactnet:8000 resolve", "server 127.0.0.1:8000")
    done = nginx_test(nginx, text, str(tmp_path))
    assert done.returncode == 0, done.stderr


def test_the_front_retries_only_refusals_and_outlasts_the_replicas_deadline():
    """A 503 comes before any work and may go to another replica; a timeout or a 504 comes
    after work started and must not (issue #31, item 7)."""
    from impactnet.service.settings import Settings

    text = nginx_conf.TEMPLATE.read_text()
    retried = re.search(r"^\s*proxy_next_upstream ([^;]+);", text, re.M).group(1).split()
    assert "http_503" in retried and "error" in retried
    assert not {"timeout", "http_504", "http_502", "http_500"} & set(retried)
    read_timeout = int(re.search(r"proxy_read_timeout (\d+)s;", text).group(1))
    compose = yaml.safe_load(COMPOSE.read_text())["services"]["impactnet"]["environment"]
    deadline = float(compose.get("IMPACTNET_COMPUTE_DEADLINE_S", Settings().compute_deadline_s))
    assert read_timeout > deadline and read_timeout > Settings().compute_deadline_s

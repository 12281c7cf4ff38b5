"""The nginx front's configuration, rendered from the one template, ``docker/nginx.conf``.

The template's placeholders are ``${NGINX_*}`` names (listed in its header). Two renderers fill
them the same way: the nginx image's entrypoint runs ``envsubst`` over it with the values of
``docker/compose.yaml`` (nginx 1.27: one server name, re-resolved with ``resolve``), and
:func:`render` here (a loopback fleet on Debian's nginx 1.22, which lacks ``resolve``: one
``server`` line per replica port). :func:`render` substitutes exactly the placeholder names,
as envsubst restricted to them does, and leaves nginx's own ``$variables`` alone.

    python -m impactnet.service.fleet.nginx_conf --listen 127.0.0.1:8000 --run-dir /tmp/front \\
        --upstream 127.0.0.1:8001 --upstream 127.0.0.1:8002 > /tmp/front/nginx.conf

The template is not part of the wheel: it is read from the repository (``docker/``).
"""
from __future__ import annotations

import argparse
import re
import sys
from pathlib import Path

#: The shipped template (repository root / docker / nginx.conf).
TEMPLATE = Path(__file__).resolve().parents[2] / "docker" / "nginx.conf"
#: The placeholder names of the template, each required by :func:`render`.
PLACEHOLDERS = ("NGINX_LISTEN", "NGINX_RUN_DIR", "NGINX_RESOLVER", "NGINX_UPSTREAM_SERVERS")
#: Options of every loopback upstream server. max_fails=0: a replica that refuses is never
#: taken out for a fail_timeout; the refusal costs one loopback connect and the request goes on
#: to the next replica (proxy_next_upstream), the same as in the compose file.
SERVER_OPTIONS = "max_fails=0"
_NAME = re.compile(r"\$\{(NGINX_[A-Z0-9_]+)\}")


class TemplateError(ValueError):
    """A placeholder without a value, or a value for a name the template does not have."""


def render(values: dict[str, str], template: str | None = None) -> str:
    """The template (``template`` text, else :data:`TEMPLATE`'s) with every ``${NAME}`` of
    ``values`` replaced; raises :class:`TemplateError` where a placeholder is left unfilled."""
    text = TEMPLATE.read_text(encoding="utf-8") if template is None else template
    missing = sorted(set(_NAME.findall(text)) - set(values))
    if missing:
        raise TemplateError(f"no value for {', '.join(missing)}")
    return _NAME.sub(lambda m: values[m.group(1)], text)


def loopback_values(upstreams: list[str], listen: str, run_dir: str) -> dict[str, str]:
    """Placeholder values of a front at ``listen`` over fixed replica addresses
    (``"127.0.0.1:8001"``), no resolver: what nginx 1.22 accepts."""
    if not upstreams:
        raise TemplateError("at least one upstream address is needed")
    servers = "\n        ".join(f"server {address} {SERVER_OPTIONS};" for address in upstreams)
    return {"NGINX_LISTEN": listen, "NGINX_RUN_DIR": run_dir, "NGINX_RESOLVER": "",
            "NGINX_UPSTREAM_SERVERS": servers}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m impactnet.service.fleet.nginx_conf",
                                     description="Render docker/nginx.conf for fixed replica "
                                     "addresses (loopback fleet) to stdout.")
    parser.add_argument("--upstream", action="append", required=True, metavar="HOST:PORT",
                        help="a replica's address (repeat for each)")
    parser.add_argument("--listen", default="127.0.0.1:8000", help="the front's address")
    parser.add_argument("--run-dir", required=True,
                        help="writable folder for the pid and temp files")
    parser.add_argument("--template", type=Path, default=TEMPLATE, help="the template")
    args = parser.parse_args(argv)
    values = loopback_values(args.upstream, args.listen, args.run_dir)
    sys.stdout.write(render(values, args.template.read_text(encoding="utf-8")))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

"""The interactive API docs work with no network (assets from an installed package, not a
CDN), and the big static bundles go over the wire gzipped."""

from __future__ import annotations

import gzip
import os

import httpx
import pytest

from api.core.service import RigService
from api.http.app import create_app
from api.http.static_assets import DOCS_ASSETS_URL, bundle
from daq.session import RigSource
from tests.api.conftest import TOKEN, LiveServer


@pytest.fixture(scope="module")
def docs_server(tmp_path_factory):
    """The app on real uvicorn; the rig itself is never started (the docs need no rig)."""
    db = tmp_path_factory.mktemp("docs") / "rig.db"
    app = create_app(RigService(RigSource.load(), f"sqlite:///{db}"), token=TOKEN,
                     manage_service=False)  # fmt: skip
    with LiveServer(app) as live:
        yield live.url


def _offline(page, base: str) -> list[str]:
    """Abort every request that is not to the test server; returns what was blocked."""
    blocked: list[str] = []

    def route(r):
        if r.request.url.startswith(base):
            r.continue_()
        else:
            blocked.append(r.request.url)
            r.abort()

    page.route("**/*", route)
    return blocked


def test_swagger_ui_renders_with_the_network_blocked(chromium, docs_server):
    with chromium.page() as page:
        blocked = _offline(page, docs_server)
        page.goto(docs_server + "/docs")
        page.wait_for_selector(".swagger-ui .opblock")
        assert page.locator(".swagger-ui .opblock").count() > 20  # one per operation
        assert page.locator(".swagger-ui .opblock-summary-path", has_text="/api/jobs/tow").count()
        assert blocked == []  # nothing was even asked of another host


def test_redoc_renders_with_the_network_blocked(chromium, docs_server):
    with chromium.page() as page:
        blocked = _offline(page, docs_server)
        page.goto(docs_server + "/redoc")
        page.wait_for_selector(".redoc-wrap [data-section-id]")
        assert page.get_by_text("/api/jobs/tow").count()
        # ReDoc's bundle fetches only its "API docs by Redocly" badge from its own CDN.
        assert all(url.endswith("/logo-mini.svg") for url in blocked), blocked


@pytest.mark.parametrize(
    "path",
    ["/static/vendor/plotly-basic.min.js", "/static/estimation.js",
     f"{DOCS_ASSETS_URL}/swagger-ui-bundle.js", f"{DOCS_ASSETS_URL}/redoc.standalone.js"],
)  # fmt: skip
def test_static_bundles_are_gzipped(docs_server, path):
    with httpx.Client() as h:  # raw bytes: no transparent decoding
        with h.stream("GET", docs_server + path, headers={"Accept-Encoding": "gzip"}) as r:
            raw = b"".join(r.iter_raw())
        assert r.status_code == 200
        assert r.headers["content-encoding"] == "gzip"
        plain = gzip.decompress(raw)
        assert len(raw) < 0.45 * len(plain), (len(raw), len(plain))
        identity = h.get(docs_server + path, headers={"Accept-Encoding": "identity"})
        assert "content-encoding" not in identity.headers and identity.content == plain


def test_a_bundle_is_compressed_once_per_version_of_its_file(tmp_path):
    js = tmp_path / "bundle.js"
    js.write_bytes(b"x = 1;\n" * 5000)
    first = bundle(js, "text/javascript", "gzip, deflate, br")
    again = bundle(js, "text/javascript", "gzip")
    assert again.body is first.body  # from memory: not compressed again for each page
    assert gzip.decompress(first.body) == js.read_bytes()
    assert first.headers["etag"] and first.headers["last-modified"]  # still cacheable
    js.write_bytes(b"y = 2;\n" * 5000)  # an upgrade: same size, newer file
    stat = js.stat()
    os.utime(js, ns=(stat.st_atime_ns, stat.st_mtime_ns + 10**9))
    newer = bundle(js, "text/javascript", "gzip")
    assert gzip.decompress(newer.body) == js.read_bytes()
    assert newer.headers["etag"] != first.headers["etag"]
    assert "content-encoding" not in bundle(js, "text/javascript", "identity").headers


def test_api_responses_are_not_compressed(docs_server):
    r = httpx.get(docs_server + "/openapi.json", headers={"Accept-Encoding": "gzip"})
    assert r.status_code == 200 and "content-encoding" not in r.headers

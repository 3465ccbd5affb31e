"""The tuner's server over HTTP (in this process): the token, the Host check, the routes, the
refusals; every asset is local."""

from __future__ import annotations

import http.client
import json
from pathlib import Path

import pytest

from fl_design.ui import make_server


@pytest.fixture(scope="module")
def served(served_tuner):
    app, httpd = served_tuner
    return app, httpd.server_address[1]


def _request(port, method, path, body=None, headers=None):
    conn = http.client.HTTPConnection("127.0.0.1", port, timeout=60)
    hdrs = {"Host": f"127.0.0.1:{port}"} | (headers or {})
    data = None
    if body is not None:
        data = body if isinstance(body, bytes) else json.dumps(body).encode()
        hdrs.setdefault("Content-Type", "application/json")
    conn.request(method, path, body=data, headers=hdrs)
    r = conn.getresponse()
    out = r.status, r.read(), r.getheader("Content-Type")
    conn.close()
    return out


def test_binds_loopback_only_with_a_long_token(served):
    app, _ = served
    httpd = make_server(app, 0)
    try:
        assert httpd.server_address[0] == "127.0.0.1"
    finally:
        httpd.server_close()
    assert len(app.token) >= 32


def test_a_taken_port_is_a_clear_error(served):
    from fl_design.errors import ParameterError

    app, port = served
    with pytest.raises(ParameterError, match=f"cannot listen on 127.0.0.1:{port}"):
        make_server(app, port)
    with pytest.raises(ParameterError, match="0..65535"):
        make_server(app, 70000)


@pytest.mark.parametrize("path", ["/", "/api/init", "/static/plotly.min.js", "/x/api/init",
                                  "//api/init"])
def test_requests_without_the_token_are_refused(served, path):
    _, port = served
    status, body, _ = _request(port, "GET", path)
    assert status == 403 and b"token" in body


def test_a_token_differing_in_one_character_is_refused(served):
    app, port = served
    wrong = app.token[:-1] + ("A" if app.token[-1] != "A" else "B")
    assert _request(port, "GET", f"/{wrong}/")[0] == 403


def test_a_foreign_host_is_refused(served):
    app, port = served
    status, body, _ = _request(port, "GET", f"/{app.token}/", headers={"Host": "evil.example"})
    assert status == 403 and b"Host" in body


def test_page_and_assets_are_local(served):
    import plotly

    app, port = served
    status, page, ctype = _request(port, "GET", f"/{app.token}/")
    assert status == 200 and ctype.startswith("text/html")
    assert b"http://" not in page and b"https://" not in page  # nothing fetched from elsewhere
    status, js, _ = _request(port, "GET", f"/{app.token}/static/plotly.min.js")
    shipped = Path(plotly.__file__).parent / "package_data" / "plotly.min.js"
    assert status == 200 and js == shipped.read_bytes()
    import fl_design.ui as ui_package

    static = Path(ui_package.__file__).parent / "static"  # the response charts' uPlot
    status, js, ctype = _request(port, "GET", f"/{app.token}/static/uPlot.iife.min.js")
    assert status == 200 and js == (static / "uPlot.iife.min.js").read_bytes()
    assert ctype.startswith("text/javascript") and b"uPlot (v1.6.32)" in js[:100]
    assert "MIT License" in (static / "uPlot.LICENSE").read_text()  # shipped beside it
    status, own, _ = _request(port, "GET", f"/{app.token}/static/tuner.js")
    assert status == 200 and b"fetch('http" not in own
    assert _request(port, "GET", f"/{app.token}/static/../_server.py")[0] == 404


def test_redraw_over_http(served):
    app, port = served
    status, body, ctype = _request(port, "POST", f"/{app.token}/api/redraw", {"gamma": 1e-3})
    data = json.loads(body)
    assert status == 200 and ctype == "application/json"
    assert data["values"]["gamma"] == 1e-3 and data["verdict"]["status"]


@pytest.mark.parametrize("body, headers, code", [
    (b"{not json", None, 400),
    ({"eps": "x"}, None, 400),
    ({"gamma": 1e-3}, {"Content-Type": "text/plain"}, 415),
    (b"x" * 70_000, None, 413),
])
def test_bad_requests_are_refused_with_a_reason(served, body, headers, code):
    app, port = served
    assert _request(port, "POST", f"/{app.token}/api/redraw", body, headers)[0] == code


def test_an_unexpected_failure_is_one_line_not_a_traceback(served, monkeypatch, capsys):
    app, port = served

    def broken(values):
        raise RuntimeError("boom")

    monkeypatch.setattr(app.tuner, "redraw", broken)
    status, body, _ = _request(port, "POST", f"/{app.token}/api/redraw", {})
    assert status == 500 and "RuntimeError: boom" in json.loads(body)["error"]
    assert "Traceback" not in capsys.readouterr().err


def test_save_takes_no_path_from_the_browser(served):
    app, port = served
    status, body, _ = _request(port, "POST", f"/{app.token}/api/save",
                               {"what": "toml", "values": {}, "path": "/tmp/x.toml"})
    assert status == 400 and b"no path" in body
    status, body, _ = _request(port, "POST", f"/{app.token}/api/save",
                               {"what": "toml", "values": {"gamma": 1e-3}})
    written = Path(json.loads(body)["written"])
    assert status == 200 and written.parent == app.out and written.name.startswith("design_")


def test_redraws_share_one_kept_alive_connection_and_a_refusal_closes_it(served):
    app, port = served
    conn = http.client.HTTPConnection("127.0.0.1", port, timeout=60)
    hdrs = {"Host": f"127.0.0.1:{port}", "Content-Type": "application/json"}
    try:
        for gamma in (5e-4, 1e-3):  # two answers on one connection
            conn.request("POST", f"/{app.token}/api/redraw",
                         body=json.dumps({"gamma": gamma}).encode(), headers=hdrs)
            r = conn.getresponse()
            view = json.loads(r.read())
            assert r.status == 200 and view["values"]["gamma"] == gamma
            assert r.getheader("Connection") != "close"
            assert r.getheader("Server-Timing").startswith("server;dur=")
        # a body too large is refused unread: the connection closes (its bytes are no request)
        conn.request("POST", f"/{app.token}/api/redraw", body=b"x" * 70_000, headers=hdrs)
        r = conn.getresponse()
        r.read()
        assert r.status == 413 and r.getheader("Connection") == "close"
    finally:
        conn.close()

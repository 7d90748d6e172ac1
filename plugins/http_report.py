"""``http`` reporter: POST the result to a course server, keeping it in the outbox until a 2xx says it arrived.

Config (``[report.http]``; ``--report-url`` sets ``url``)::

    [report.http]
    url = "https://course.example.org/api/robotics/result/"
    token_env = "ROBOKIT_TOKEN"   # the NAME of an environment variable holding a bearer token (optional)
    outbox = "outbox"             # folder for undelivered results, relative to the working directory

Retries (connection errors, timeouts, 5xx, 408, 429) are urllib3's :class:`~urllib3.util.retry.Retry` mounted on a
requests :class:`~requests.adapters.HTTPAdapter`: exponential backoff with jitter, ``Retry-After`` honoured (up to
``retry_after_max``). The run id is the ``Idempotency-Key`` header. The token is read from the environment at send
time, sent as ``Authorization: Bearer ...``, and never written anywhere. ``requests`` is imported only when a
result is sent, so loading the plugin costs nothing.
"""

from __future__ import annotations

import dataclasses
import inspect
import json
import os
import re
from dataclasses import asdict, dataclass, fields
from pathlib import Path
from typing import Any

from pydantic import Field, field_validator, model_validator

from robokit import __version__, hookimpl
from robokit.components import Delivery, Reporter
from robokit.config import Schema
from robokit.errors import Interrupted
from robokit.report.outbox import Entry, Outbox, SendResult, fingerprint
from robokit.report.reporting import Refused

RETRY_STATUSES = frozenset([408, 429, *range(500, 600)])
"""Answers worth retrying: request timeout, too many requests, and every server error."""
_MAX_BODY = 4096
_ENV_NAME = r"^[A-Za-z_][A-Za-z0-9_]*$"
DEFAULT_TOKEN_ENV = "ROBOKIT_TOKEN"
"""The variable a token is read from when no ``token_env`` is named (sent only when it is set)."""


class HttpReportConfig(Schema):
    """``[report.http]``. Times in seconds, sizes in bytes."""

    url: str = Field("", validate_default=True, description="where to POST, e.g. http://host/api/robotics/result/")
    token_env: str | None = Field(None, description="env var NAME holding a bearer token")
    connect_timeout: float = Field(3.05, gt=0)
    read_timeout: float = Field(10.0, gt=0)
    retries: int = Field(4, ge=0, le=20, description="retries after the first try (urllib3 Retry total)")
    backoff_factor: float = Field(0.5, ge=0, description="sleep backoff_factor * 2**(n-1) before retry n>1")
    backoff_max: float = Field(30.0, ge=0)
    backoff_jitter: float = Field(0.5, ge=0, description="uniform random extra sleep, 0..jitter seconds")
    retry_after_max: float = Field(120.0, ge=0, description="cap on a server's Retry-After")
    verify: bool | str = Field(True, description="TLS verification: true, false, or a CA bundle path")
    max_payload_bytes: int = Field(1_000_000, ge=1)
    outbox: str = Field("outbox", min_length=1)
    flush_outbox: bool = Field(True, description="after delivering, send entries waiting in the outbox")
    upload_artifacts: bool = Field(False, description="after delivering, upload the run folder's video, plots, "
                                   "trace and config to <url><run_id>/artifacts/")
    artifacts_dir: str = Field("results", min_length=1, description="folder holding run folders <run_id>/")

    @model_validator(mode="before")
    @classmethod
    def _no_secret_here(cls, data: Any) -> Any:
        if isinstance(data, dict) and {"token", "bearer", "password", "api_key"} & data.keys():
            raise ValueError("never put a token in the config file: set token_env = the NAME of an environment "
                             "variable that holds it")
        return data

    @field_validator("token_env")
    @classmethod
    def _env_name(cls, name: str | None) -> str | None:
        if name is not None and not re.match(_ENV_NAME, name):
            raise ValueError("expected the NAME of an environment variable (letters, digits, _), got something "
                             "else (not shown: it may be the token itself, which must not be in the config)")
        return name

    @field_validator("url")
    @classmethod
    def _http_url(cls, url: str) -> str:
        if not url:
            raise ValueError('missing: give url = "http://host/api/robotics/result/" or --report-url URL')
        problem = url_problem(url)
        if problem:
            raise ValueError(f"{problem}, got {url!r}")
        return url

    @field_validator("verify")
    @classmethod
    def _ca_bundle(cls, verify: bool | str) -> bool | str:
        if isinstance(verify, str) and not os.path.exists(verify):
            raise ValueError(f"expected true, false or the path of a CA bundle; {verify!r} does not exist")
        return verify


def url_problem(url: str) -> str | None:
    """Why ``url`` can never be POSTed to (no scheme or host, a bad port, a space...), or None if it looks fine."""
    from urllib.parse import urlsplit

    if any(ch.isspace() or ord(ch) < 32 or ord(ch) == 127 for ch in url):
        return "a URL cannot contain spaces or control characters (encode a space as %20)"
    if not url.startswith(("http://", "https://")):
        return "expected an http:// or https:// URL"
    try:
        parts = urlsplit(url)
        port = parts.port  # raises ValueError for a port that is not a number in 0-65535
    except ValueError as exc:
        return f"not a valid URL ({exc})"
    if not parts.hostname:
        return "the URL has no host name"
    if port == 0:
        return "port 0 cannot be connected to"
    return None


@dataclass(frozen=True)
class HttpOptions:
    """How to send: everything an outbox entry needs to be sent later, and nothing secret."""

    connect_timeout: float = 3.05
    read_timeout: float = 10.0
    retries: int = 4
    backoff_factor: float = 0.5
    backoff_max: float = 30.0
    backoff_jitter: float = 0.5
    retry_after_max: float = 120.0
    verify: bool | str = True
    max_payload_bytes: int = 1_000_000
    token_env: str | None = None
    upload_artifacts: bool = False
    artifacts_dir: str = "results"

    @classmethod
    def from_mapping(cls, data: Any) -> HttpOptions:
        """From a config model or an entry's ``options`` dict (unknown keys ignored, missing ones default)."""
        get = data.get if isinstance(data, dict) else lambda k, d: getattr(data, k, d)
        return cls(**{f.name: get(f.name, f.default) for f in fields(cls)})

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)


def make_session(opts: HttpOptions) -> Any:
    """A requests Session whose adapter retries with urllib3's Retry (POST included, Retry-After honoured)."""
    import requests
    from requests.adapters import HTTPAdapter
    from urllib3.util.retry import Retry

    kwargs: dict[str, Any] = dict(
        total=opts.retries, connect=None, read=None, redirect=0, status=None, other=0,
        allowed_methods=frozenset({"POST"}), status_forcelist=RETRY_STATUSES,
        backoff_factor=opts.backoff_factor, backoff_max=opts.backoff_max, backoff_jitter=opts.backoff_jitter,
        respect_retry_after_header=True, raise_on_status=False, raise_on_redirect=False,
    )
    if "retry_after_max" in inspect.signature(Retry).parameters:  # urllib3 >= 2.6
        kwargs["retry_after_max"] = opts.retry_after_max
    adapter = HTTPAdapter(max_retries=Retry(**kwargs))
    session = requests.Session()  # honours HTTPS_PROXY / NO_PROXY / REQUESTS_CA_BUNDLE like any requests client
    session.mount("http://", adapter)
    session.mount("https://", adapter)
    return session


def encode(payload: dict[str, Any]) -> bytes:
    """The request body: compact UTF-8 JSON."""
    return json.dumps(payload, separators=(",", ":"), ensure_ascii=False).encode("utf-8")


class HttpSender:
    """Sends outbox entries (a :data:`robokit.report.outbox.Sender`). ``url`` overrides each entry's URL,
    ``token_env`` each entry's token variable.

    The token: from the variable the entry (its config) names, else from ``$ROBOKIT_TOKEN`` when that is set. A
    named variable that is unset is a refusal (the result is not sent without the token its maker asked for).
    After a 2xx, the run folder's files are uploaded when the entry's config asked (``upload_artifacts``).
    """

    def __init__(self, url: str | None = None, token_env: str | None = None) -> None:
        self.url = url
        self.token_env = token_env
        self._sessions: dict[HttpOptions, Any] = {}

    def target(self, entry: Entry) -> str:
        """Where an entry is really sent (the override URL, else the entry's own)."""
        return self.url or entry.url

    def token(self, entry: Entry) -> tuple[str, str | None, bool]:
        """(variable name, token or None, whether the name was asked for explicitly) for sending ``entry``."""
        named = self.token_env or HttpOptions.from_mapping(entry.options).token_env
        name = named or DEFAULT_TOKEN_ENV
        return name, os.environ.get(name) or None, named is not None

    def identity(self, entry: Entry) -> str:
        """Who would send ``entry`` now: the token's fingerprint, or "no token"."""
        return fingerprint(self.token(entry)[1])

    def __call__(self, entry: Entry) -> SendResult:
        url = self.target(entry)
        problem = url_problem(url)
        if problem:  # it can never be delivered: refuse it for good (to failed/), do not block the others
            return SendResult(False, True, None, f"malformed URL {url!r}: {problem}; not sent")
        opts = HttpOptions.from_mapping(entry.options)
        body = encode(entry.payload)
        if len(body) > opts.max_payload_bytes:
            return SendResult(False, True, None, f"payload is {len(body)} bytes, over the "
                              f"{opts.max_payload_bytes}-byte limit (max_payload_bytes): not sent")
        name, token, named = self.token(entry)
        if named and not token:
            return SendResult(False, True, None, f"environment variable {name} is not set: not sent",
                              advice=f"export {name}=... (the token your teacher gave you), then "
                                     f"`robokit outbox retry {entry.run_id}`")
        if opts not in self._sessions:
            self._sessions[opts] = make_session(opts)
        result = post(self._sessions[opts], url, body, entry.run_id, opts, token)
        if result.ok and opts.upload_artifacts:
            result = _upload(result, entry, url, opts, token)
        elif result.permanent and result.status is not None:
            result = dataclasses.replace(result, advice=advice(result, name, token, entry.run_id))
        return _redact(result, token)

    def close(self) -> None:
        for session in self._sessions.values():
            session.close()
        self._sessions.clear()


def _upload(result: SendResult, entry: Entry, url: str, opts: HttpOptions, token: str | None) -> SendResult:
    """After the result arrived, upload its run folder's files; a failure is told, never changes the delivery."""
    from robokit.report.artifact_upload import find_artifacts, upload_artifacts

    files = find_artifacts(os.path.join(opts.artifacts_dir, entry.run_id), entry.payload.get("config"))
    if not files:
        return result
    note = upload_artifacts(url, entry.run_id, files, token=token, verify=opts.verify,
                            timeout=(opts.connect_timeout, max(opts.read_timeout, 60.0)))
    return dataclasses.replace(result, note=note)


def server_error(body: str) -> tuple[str, str | None]:
    """The course server's ``{"error": ..., "field": ...}`` answer as (message, field); other bodies as text."""
    try:
        data = json.loads(body)
    except ValueError:
        data = None
    if isinstance(data, dict) and isinstance(data.get("error"), str):
        field = data.get("field")
        return " ".join(data["error"].split())[:300], field if isinstance(field, str) else None
    return " ".join(body.split())[:200], None


def advice(result: SendResult, name: str, token: str | None, run_id: str) -> str:
    """What to change after a refusal, in one line, ending with how to send the result again."""
    message, field = server_error(result.body)
    again = f"then `robokit outbox retry {run_id}`"
    if result.status == 401 and not token:
        return f"no token sent: export {name}=... (the token your teacher gave you), {again}"
    if field == "student" and not token:  # a class that wants tokens, or a name left out: say both
        return (f"{message}: no token sent: export {name}=... (the token your teacher gave you), {again} "
                f"(in a class without tokens: `robokit outbox retry {run_id} --student NAME`)")
    if result.status == 401:
        return (f"the server did not accept the token in ${name} ({message}): check it or ask your teacher for "
                f"a new one, {again}")
    if field in ("project", "student"):
        return (f"{field}: {message}: give --{field} NAME (or [report] {field} = \"NAME\"); this result: "
                f"`robokit outbox retry {run_id} --{field} NAME`")
    if field:
        return f"{field}: {message}: change it in the config, run again (or fix the server), {again}"
    return f"the server said: {message or 'HTTP ' + str(result.status)}; once that is fixed, {again}"


def post(session: Any, url: str, body: bytes, run_id: str, opts: HttpOptions, token: str | None) -> SendResult:
    """POST once through the retrying session; classify the final answer or error."""
    import requests

    headers = {"Content-Type": "application/json", "Idempotency-Key": run_id,
               "User-Agent": f"robokit/{__version__}"}
    try:
        resp = session.post(url, data=body, headers=headers, timeout=(opts.connect_timeout, opts.read_timeout),
                            verify=opts.verify, allow_redirects=False, auth=_Bearer(token) if token else None)
    except (requests.exceptions.InvalidURL, requests.exceptions.InvalidSchema,
            requests.exceptions.MissingSchema) as exc:  # can never work: refused for good
        return SendResult(False, True, None, f"malformed URL {url!r}: {' '.join(str(exc).split())[:160]}")
    except requests.RequestException as exc:
        return SendResult(False, False, None, _describe(exc, opts))
    except OSError as exc:  # not the network: e.g. the CA bundle named by `verify` cannot be read
        return SendResult(False, False, None, f"could not send ({type(exc).__name__}: {exc})")
    text = resp.text[:_MAX_BODY]
    first_line = " ".join(text.split())[:200]
    if 200 <= resp.status_code < 300:
        return SendResult(True, False, resp.status_code, f"HTTP {resp.status_code}", text)
    if 400 <= resp.status_code < 500 and resp.status_code not in RETRY_STATUSES:
        return SendResult(False, True, resp.status_code, f"HTTP {resp.status_code}: {first_line}", text)
    if 300 <= resp.status_code < 400:
        where = resp.headers.get("Location", "?")
        return SendResult(False, False, resp.status_code,
                          f"HTTP {resp.status_code}: the server redirects to {where}; flush with --url set to it")
    return SendResult(False, False, resp.status_code, f"HTTP {resp.status_code} after retries: {first_line}", text)


class _Bearer:
    """``Authorization: Bearer <token>`` as a requests auth object (so a ``.netrc`` entry cannot replace it)."""

    def __init__(self, token: str) -> None:
        self._token = token

    def __call__(self, request: Any) -> Any:
        request.headers["Authorization"] = f"Bearer {self._token}"
        return request

    def __repr__(self) -> str:
        return "_Bearer(***)"


def _describe(exc: Exception, opts: HttpOptions) -> str:
    """One line for a requests error (never the headers): what kind of failure, and its root cause."""
    from urllib3.exceptions import ConnectTimeoutError, NewConnectionError, ReadTimeoutError, SSLError

    chain = _causes(exc)
    after = f"after {opts.retries} retries"
    refused = any(isinstance(e, NewConnectionError) for e in chain)  # a subclass of ConnectTimeoutError
    if not refused and any(isinstance(e, ConnectTimeoutError) for e in chain):
        return f"connect timed out ({opts.connect_timeout} s), {after}"
    if any(isinstance(e, ReadTimeoutError) for e in chain):
        return f"no answer within the read timeout ({opts.read_timeout} s), {after}"
    kind = "TLS error" if any(isinstance(e, SSLError) for e in chain) else "connection failed"
    cause = " ".join(str(chain[-1]).split())[:160]
    return f"{kind}: {cause}, {after}"


def _causes(exc: BaseException) -> list[BaseException]:
    """``exc`` and what it wraps (requests' ``args[0]``, urllib3's ``reason``, ``__cause__``/``__context__``)."""
    chain = [exc]
    while len(chain) < 20:
        cur = chain[-1]
        nxt = getattr(cur, "reason", None)
        if not isinstance(nxt, BaseException) and cur.args and isinstance(cur.args[0], BaseException):
            nxt = cur.args[0]
        if not isinstance(nxt, BaseException):
            nxt = cur.__cause__ or cur.__context__
        if not isinstance(nxt, BaseException) or any(nxt is e for e in chain):
            break
        chain.append(nxt)
    return chain


def _redact(result: SendResult, token: str | None) -> SendResult:
    """Blank the token out of anything the server echoed back (it is written to files and printed)."""
    texts = ("detail", "body", "note", "advice")
    if not token or not any(token in getattr(result, name) for name in texts):
        return result
    return dataclasses.replace(result, **{name: getattr(result, name).replace(token, "***") for name in texts})


class HttpReporter(Reporter):
    """POSTs the payload; on failure the payload waits in the outbox (see :mod:`robokit.report.outbox`)."""

    sends = True

    def keep(self, payload: dict[str, Any]) -> Delivery:
        """The run was interrupted: queue the payload in the outbox without sending it (a flush sends it)."""
        cfg: HttpReportConfig = self.config
        outbox = Outbox(cfg.outbox)
        try:
            with outbox.lock(str(payload["run_id"])):
                entry = outbox.put(payload, cfg.url, HttpOptions.from_mapping(cfg).to_dict(),
                                   last_error="not sent: the run was interrupted (Ctrl-C / SIGTERM)",
                                   identity=self._identity(payload))
        except OSError as exc:
            return Delivery(False, None, f"not sent (interrupted) and the outbox {outbox.root} could not be "
                            f"written: {exc}")
        return Delivery(False, str(entry.path), f"not sent (interrupted); result kept in the outbox {entry.path} - "
                        f"`robokit outbox flush --dir {outbox.root}` sends it")

    def _identity(self, payload: dict[str, Any]) -> str:
        """Who makes this entry: the fingerprint of the token it is sent with (see :meth:`HttpSender.token`)."""
        probe = Entry(Path("-"), {"options": HttpOptions.from_mapping(self.config).to_dict(), "payload": payload})
        return HttpSender().identity(probe)

    def report(self, payload: dict[str, Any]) -> Delivery:
        cfg: HttpReportConfig = self.config
        opts = HttpOptions.from_mapping(cfg)
        outbox = Outbox(cfg.outbox)
        sender = HttpSender()
        try:
            delivery = self._send_own(outbox, sender, payload, opts)
            if delivery.delivered and cfg.flush_outbox:
                delivery = _with_flush(delivery, outbox, sender, cfg.url)
            return delivery
        finally:
            sender.close()

    def _send_own(self, outbox: Outbox, sender: HttpSender, payload: dict[str, Any], opts: HttpOptions) -> Delivery:
        url = self.config.url
        run_id = str(payload["run_id"])
        identity = self._identity(payload)
        try:
            with outbox.lock(run_id):
                entry = outbox.put(payload, url, opts.to_dict(), identity=identity)  # write-ahead: a crash resends
                outcome, entry, result = outbox.attempt(entry, sender)
                outbox.drop_lock_file(run_id)
        except Interrupted as exc:  # Ctrl-C while sending: the entry was written first, so it waits in the outbox
            path = outbox.path_for(run_id)
            kept = path if path.exists() else None
            return Delivery(False, str(kept) if kept else None,
                            f"interrupted ({exc.reason}) while sending; "
                            + (f"result kept in the outbox {kept} - `robokit outbox flush --dir {outbox.root}` "
                               "sends it" if kept else "not kept in the outbox"))
        except OSError as exc:  # the outbox cannot be written (sending never raises it): deliver without a net
            result = sender(Entry(outbox.path_for(run_id), {
                "run_id": run_id, "url": url, "payload": payload, "options": opts.to_dict()}))
            if result.ok:
                return Delivery(True, None, _delivered(url, result))
            return Delivery(False, None, f"not delivered ({result.detail}) and the outbox {outbox.root} "
                            f"could not be written: {exc}")
        if outcome == "delivered":
            return Delivery(True, None, _delivered(url, result))
        if outcome == "failed":
            return Refused(False, str(entry.path), f"REFUSED ({result.detail}); kept in {entry.path}",
                           why=result.detail, advice=result.advice, status=result.status)
        return Delivery(False, str(entry.path), f"not delivered ({result.detail}); result kept in the outbox "
                        f"{entry.path} - `robokit outbox flush --dir {outbox.root}` sends it later")


def _delivered(url: str, result: SendResult) -> str:
    return f"delivered to {url} ({result.detail})" + (f"; {result.note}" if result.note else "")


def _with_flush(delivery: Delivery, outbox: Outbox, sender: HttpSender, url: str) -> Delivery:
    """After this run's own delivery worked, send what waits in the outbox for the same URL.

    Entries made for other URLs are left alone (that server was not just shown to be up). A failure here changes
    nothing about this run's own report.
    """
    try:
        if not any(e.url == url for e in outbox.entries()):
            return delivery
        report = outbox.flush(sender, url=url)
    except Exception as exc:  # noqa: BLE001 - flushing older results never changes this run's report
        return Delivery(True, None, f"{delivery.message}; outbox flush failed: {type(exc).__name__}: {exc}")
    return Delivery(True, None, f"{delivery.message}; outbox {outbox.root}: {report.counts()}")


@hookimpl
def robokit_register_reporters(register):  # type: ignore[no-untyped-def]
    register("http", HttpReporter, HttpReportConfig)

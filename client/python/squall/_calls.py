"""The synchronous call layer: per-call metadata and deadlines, SquallError, stream iterators."""

from __future__ import annotations

import ipaddress
import json
import numbers
import os
import queue
import secrets
import threading
import time
import warnings
from typing import (
    Any,
    Callable,
    Generic,
    Iterable,
    Iterator,
    List,
    Optional,
    Protocol,
    Tuple,
    TypeVar,
    cast,
)

import grpc

from squall._convert import integer, shown
from squall._errors import REPLICA_KEY, PlaintextTokenWarning, SquallError

T = TypeVar("T")

DEFAULT_ADDRESS = "127.0.0.1:50051"
# squalld enforces its own --max-message-bytes; the client takes whatever it is sent (as the C++
# client).
CHANNEL_OPTIONS: List[Tuple[str, Any]] = [
    ("grpc.max_receive_message_length", -1),
    ("grpc.max_send_message_length", -1),
]

# A channel with a connection of its own (GRPC_ARG_USE_LOCAL_SUBCHANNEL_POOL, as the C++
# client's own_connection): by default the channels of one process to one address with the same
# options share one connection.
OWN_CONNECTION_OPTIONS: List[Tuple[str, Any]] = [("grpc.use_local_subchannel_pool", 1)]

# Metadata keys (server/rpc/metadata.h; x-squall-replica: squall._errors.REPLICA_KEY).
REQUEST_ID_KEY = "x-request-id"
SESSION_KEY = "x-squall-session"
AUTHORIZATION_KEY = "authorization"

SERVICES = ("Server", "Ocean", "EWave", "Clouds", "Textures")

# Requests of a bidirectional call fed from an iterable that may be read ahead of the replies the
# caller has taken (RequestFeeder): one to keep the server busy while the caller handles a reply,
# one in transit. A caller that stops reading after reply n has had at most n + RUN_AHEAD requests
# sent, so an eWave Run stream it leaves has applied at most RUN_AHEAD steps beyond its last frame.
RUN_AHEAD = 2

# The longest deadline sent, s (about 3 years). gRPC turns a timeout into an absolute deadline and
# fails a call whose deadline it cannot represent at once, without sending it (DEADLINE_EXCEEDED
# for about 1e10 s and more): a longer timeout, like inf, is sent as no deadline.
MAX_TIMEOUT = 1e8


def retry_options(attempts: int) -> List[Tuple[str, Any]]:
    """Channel options that retry calls answered UNAVAILABLE (squalld starting or draining, a
    replica gone behind a proxy, a session being handed over) up to `attempts` times in all, with
    exponential backoff from 0.1 s to 2 s; none for attempts 0 or 1 (no retry policy). TypeError
    or ValueError naming ``retries`` for anything but an integer >= 0.

    gRPC retries only calls the server has not begun to answer; squalld answers UNAVAILABLE before
    it touches a session, and an eWave step's retry key makes a step whose reply was lost (a
    broken connection, a proxy's retry on another replica) once, unless another caller steps the
    session in between. An eWave Run is never retried: its steps carry no retry key, and a
    connection lost after a step but before its frame would replay that step.
    """
    attempts = integer(attempts, "retries", 0)
    if attempts <= 1:
        # No retry policy, as the C++ client; gRPC's transparent retries (of calls that never
        # reached the server) stay on.
        return []
    policy = {
        "maxAttempts": min(attempts, 5),
        "initialBackoff": "0.1s",
        "maxBackoff": "2s",
        "backoffMultiplier": 2,
        "retryableStatusCodes": ["UNAVAILABLE"],
    }
    names = [{"service": f"squall.v1.{s}"} for s in SERVICES]
    run = {"service": "squall.v1.EWave", "method": "Run"}  # the most specific name wins
    config = {"methodConfig": [{"name": names, "retryPolicy": policy}, {"name": [run]}]}
    return [("grpc.enable_retries", 1), ("grpc.service_config", json.dumps(config))]


def cancelled_unanswered(error: grpc.RpcError) -> bool:
    """Whether a unary call's `error` is CANCELLED with no x-squall-replica in its response: squalld
    sent no answer (it names itself in every answer it sends). gRPC ends so a call that reaches a
    server as it closes, before any handler runs: a proxy without health checks (nginx) sends a
    draining replica calls until its port closes. The client sends such a call again: squall's
    unary calls are idempotent or keyed (an eWave step's retry_key, a session's proposed id), so
    one that did run before it was cancelled (it outlasted a draining squalld's grace period)
    does no harm run again."""
    call = cast(grpc.Call, error)  # see SquallError.from_rpc
    try:
        if call.code() != grpc.StatusCode.CANCELLED:
            return False
        metadata = tuple(call.initial_metadata() or ()) + tuple(call.trailing_metadata() or ())
    except Exception:  # an RpcError that is not a Call: not known to be unanswered
        return False
    return all(key != REPLICA_KEY for key, _ in metadata)


class Resends:
    """The sends of one unary call: its deadline, and whether (and when) to send it again after an
    error: while it is cancelled unanswered (cancelled_unanswered), up to `retries` sends in all
    (counted apart from the retry policy's attempts within each send), 0.1 s after the first,
    then twice as long each time, none once the pause would reach the deadline."""

    def __init__(self, settings: "Settings", seconds: Optional[float]) -> None:
        self.settings = settings
        self.ends = None if seconds is None else time.monotonic() + seconds
        self.attempt = 1

    def timeout(self) -> Optional[float]:
        """Seconds left to the call's deadline (None: no deadline), at least 0."""
        return None if self.ends is None else max(0.0, self.ends - time.monotonic())

    def pause(self, error: grpc.RpcError, method: str) -> float:
        """Seconds to wait before the next send after `error`; SquallError when there is none."""
        backoff, left = 0.1 * 2.0 ** (self.attempt - 1), self.timeout()
        done = self.attempt >= self.settings.attempts or self.settings.closed
        if done or (left is not None and left <= backoff) or not cancelled_unanswered(error):
            raise SquallError.from_rpc(error, method) from None
        self.attempt += 1
        return backoff


# The creating calls that may have made their session all the same: those the client gave up on, and
# those that found their proposed id taken (by an earlier attempt of the same call, its answer lost);
# and what undoes one: (method name, function, request) of the closing call for the proposed id,
# sent with UNDO_TIMEOUT.
UNDONE = (
    grpc.StatusCode.DEADLINE_EXCEEDED,
    grpc.StatusCode.CANCELLED,
    grpc.StatusCode.ALREADY_EXISTS,
)
UNDO_TIMEOUT = 1.0  # s: what a give-up adds to the call at most
Undo = Tuple[str, Callable[..., Any], Any]


def propose_session_id(prefix: str = "") -> str:
    """A fresh session id for a call that creates a session: sent as x-squall-session, it routes
    the creating call through a session-affine proxy like the session's later calls (squalld takes
    it as the session's id). 128 random bits in lowercase hex, after `prefix` ("cloud-" for
    stored volumes)."""
    return prefix + secrets.token_hex(16)


Metadata = Tuple[Tuple[str, str], ...]

TOKEN_VARIABLE = "SQUALL_TOKEN"


def resolve_token(token: Optional[str], token_file: Optional[str]) -> Optional[str]:
    """The bearer token a client sends, as the squall CLI chooses it: `token`, else the first word
    of `token_file`, else $SQUALL_TOKEN; None (nothing sent) when none is set."""
    if token is not None:
        return token
    if token_file is not None:
        with open(token_file, encoding="utf-8") as f:
            words = f.read().split()
        if not words:
            raise ValueError(f"token_file {token_file}: no token in it")
        return words[0]
    return os.environ.get(TOKEN_VARIABLE) or None


def address_of(address: Any) -> str:
    """The "host:port" of a squalld (a str); TypeError naming ``address`` else."""
    if not isinstance(address, str):
        raise TypeError(f'address = {shown(address)}: want "host:port" (a str)')
    return address


def is_loopback(address: str) -> bool:
    """Whether gRPC target `address` is this machine: localhost, a loopback IP (127.0.0.0/8, ::1;
    "host:port", "[host]:port", with or without an ipv4:, ipv6: or dns:/// scheme; every one of a
    list) or a unix socket."""
    target = address
    for scheme in ("dns:///", "ipv4:", "ipv6:"):
        target = target[len(scheme) :] if target.startswith(scheme) else target
    if target.startswith(("unix:", "unix-abstract:")):
        return True
    if "," in target:  # an ipv4: or ipv6: list: loopback only if every address is
        return all(is_loopback(part) for part in target.split(","))
    if target.startswith("["):
        host = target[1 : target.find("]")] if "]" in target else target
    else:
        host = target.rsplit(":", 1)[0] if target.count(":") == 1 else target
    if host == "localhost":
        return True
    try:
        return ipaddress.ip_address(host).is_loopback
    except ValueError:
        return False


def warn_plaintext_token(address: str, token: Optional[str], tls: bool) -> None:
    """PlaintextTokenWarning when `token` would go to `address`, not this machine, without TLS."""
    if token and not tls and not is_loopback(address):
        warnings.warn(
            f"squall: the bearer token goes to {address} in plaintext (no TLS credentials): "
            "anyone on the path can read it",
            PlaintextTokenWarning,
            stacklevel=3,
        )


def seconds(name: str, value: Optional[float]) -> Optional[float]:
    """A deadline as given: None, or seconds > 0 (``inf``, or more than MAX_TIMEOUT: none);
    TypeError or ValueError naming `name` else (NaN or a negative one expired at once)."""
    if value is None:
        return None
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise TypeError(f"{name} must be a number of seconds or None, not {type(value).__name__}")
    if not value > 0:
        raise ValueError(f"{name} = {value}: a number of seconds > 0, inf or None")
    return value


def metadata_value(name: str, value: Optional[str]) -> Optional[str]:
    """`value` as gRPC sends metadata, a str of printable ASCII; TypeError or ValueError naming
    `name`, never quoting the value (a token), else."""
    if value is not None and not isinstance(value, str):
        raise TypeError(f"{name} must be a str or None, not {type(value).__name__}")
    if value is not None and not all(" " <= c <= "~" for c in value):
        raise ValueError(f"{name} holds a character that is not printable ASCII, as metadata is")
    return value


class Settings:
    """What every call of one client carries: deadlines, the bearer token, the request id; and
    whether the client is closed."""

    def __init__(
        self,
        timeout: Optional[float],
        stream_timeout: Optional[float],
        token: Optional[str],
        request_id: Optional[str],
        attempts: int = 1,
    ) -> None:
        self.timeout = seconds("timeout", timeout)
        # sends of a unary call cancelled unanswered (cancelled_unanswered)
        self.attempts = max(1, min(integer(attempts, "retries", 0), 5))
        self.stream_timeout = seconds("stream_timeout", stream_timeout)
        self.token = metadata_value("the token", token)
        self.request_id = metadata_value("request_id", request_id)
        self.closed = False

    def metadata(self, session: Optional[str] = None) -> Metadata:
        """authorization: Bearer <token>, x-request-id and x-squall-session, those that are set.
        Every call asks for them first: a closed client's raises RuntimeError here."""
        if self.closed:
            raise RuntimeError("this squall client is closed: make a new one")
        items = []
        if self.token:
            items.append((AUTHORIZATION_KEY, f"Bearer {self.token}"))
        if self.request_id:
            items.append((REQUEST_ID_KEY, self.request_id))
        if session:
            items.append((SESSION_KEY, session))
        return tuple(items)

    def deadline(self, timeout: Optional[float], stream: bool) -> Optional[float]:
        """Seconds for one call: `timeout`, else the client's default (unary calls or streams);
        None (no deadline) for none, inf or more than MAX_TIMEOUT."""
        if timeout is None:
            timeout = self.stream_timeout if stream else self.timeout
        else:
            seconds("timeout", timeout)
        if timeout is None or timeout > MAX_TIMEOUT:
            return None
        return float(timeout)


class Connection:
    """A channel and the client's Settings; runs calls and turns gRPC errors into SquallError."""

    def __init__(self, channel: grpc.Channel, settings: Settings) -> None:
        self.channel = channel
        self.settings = settings

    def unary(
        self,
        method: str,
        function: Callable[..., Any],
        request: Any,
        timeout: Optional[float] = None,
        session: Optional[str] = None,
    ) -> Any:
        """function(request) within the call's deadline, sent again while it is cancelled
        unanswered (Resends)."""
        sends = Resends(self.settings, self.settings.deadline(timeout, stream=False))
        while True:
            metadata = self.settings.metadata(session)  # RuntimeError once the client is closed
            try:
                return function(request, timeout=sends.timeout(), metadata=metadata)
            except grpc.RpcError as error:
                pause = sends.pause(error, method)
            time.sleep(pause)

    def create(
        self,
        method: str,
        function: Callable[..., Any],
        request: Any,
        timeout: Optional[float],
        prefix: str,
        undo: Callable[[str], Undo],
    ) -> Any:
        """A call that creates a session under an id it proposes, propose_session_id(prefix). When
        the client gives up on it (its deadline passes, it is cancelled) squalld may have made the
        session all the same, which nothing would then close: undo(id), the closing call, is sent,
        best effort, before the error is raised. ALREADY_EXISTS for an id drawn here (128 random
        bits) means that an earlier attempt of this call made the session and its answer was lost
        (a retry after a broken connection): that session is closed and the call made once more,
        under a fresh id, with a deadline of its own (so such a call may take twice its timeout)."""

        def once() -> Any:
            proposed = propose_session_id(prefix)
            try:
                return self.unary(method, function, request, timeout, session=proposed)
            except SquallError as error:
                if error.code in UNDONE:
                    try:
                        self.unary(*undo(proposed), UNDO_TIMEOUT, session=proposed)
                    except Exception:  # never made, squalld unreachable or the client closed:
                        pass  # the session's idle TTL ends it
                raise

        try:
            return once()
        except SquallError as error:
            if error.code != grpc.StatusCode.ALREADY_EXISTS:
                raise
        return once()

    def stream(
        self,
        method: str,
        function: Callable[..., Any],
        request: Any,
        convert: Callable[[Any], Optional[T]],
        timeout: Optional[float] = None,
        session: Optional[str] = None,
        feeder: Optional["RequestFeeder"] = None,
        finish: Optional[Callable[[], None]] = None,
    ) -> "Stream[T]":
        """A server-streaming or bidirectional call (request: a message or an iterator of them);
        `finish`, if given, is called when the call ends normally (see Stream)."""
        try:
            call = function(
                request,
                timeout=self.settings.deadline(timeout, stream=True),
                metadata=self.settings.metadata(session),
            )
        except grpc.RpcError as error:
            raise SquallError.from_rpc(error, method) from None
        return Stream(call, method, convert, feeder, finish)


class Stream(Iterator[T], Generic[T]):
    """An iterator over the messages of a streaming call, converted (numpy arrays).

    The call ends when the server has sent everything, when ``cancel()`` (or ``close()``) is
    called, when a ``with`` block around it ends, or when the iterator is garbage-collected; a
    cancelled stream frees its --max-streams slot on the server. Errors raise SquallError while
    iterating.

    `convert` turns each message into an item, or None for a part of one (a chunk of a frame);
    `finish`, called when the call ends normally, raises when the messages ended inside an item.
    """

    def __init__(
        self,
        call: Any,
        method: str,
        convert: Callable[[Any], Optional[T]],
        feeder: Optional["RequestFeeder"] = None,
        finish: Optional[Callable[[], None]] = None,
    ) -> None:
        self._call = call
        self._method = method
        self._convert = convert
        self._cancelled = False
        self._feeder = feeder
        self._finish = finish

    def __iter__(self) -> "Stream[T]":
        return self

    def __next__(self) -> T:
        while True:
            try:
                message = next(self._call)
            except StopIteration:
                self._end_feeder()
                if self._finish is not None:
                    self._finish()
                raise
            except grpc.RpcError as error:
                if self._cancelled and error.code() == grpc.StatusCode.CANCELLED:
                    self._end_feeder()
                    raise StopIteration from None
                failed = SquallError.from_rpc(error, self._method)
                self._end_feeder(failed)
                raise failed from None
            try:
                item = self._convert(message)
            except BaseException:
                self.cancel()  # the server would stream on, holding its --max-streams slot
                raise
            if item is not None:  # None: a partial message (a chunk of a frame)
                if self._feeder is not None:
                    self._feeder.taken()
                return item

    def _end_feeder(self, failed: Optional[SquallError] = None) -> None:
        """The call has ended: the feeder stops waiting; its error, if any, is raised (see
        raise_feeder_error)."""
        if self._feeder is None:
            return
        self._feeder.close()
        raise_feeder_error(self._feeder, failed)

    def cancel(self) -> None:
        """Ends the call now (no-op when it already ended); iteration then stops."""
        self._cancelled = True
        self._call.cancel()
        if self._feeder is not None:
            self._feeder.close()

    close = cancel

    @property
    def method(self) -> str:
        return self._method

    def __enter__(self) -> "Stream[T]":
        return self

    def __exit__(self, *exc: Any) -> None:
        self.cancel()

    def __del__(self) -> None:
        try:
            self._call.cancel()
            if self._feeder is not None:
                self._feeder.close()
        except Exception:
            pass


class FeederError(Protocol):
    """The request side of a call fed from an iterable (RequestFeeder, squall.aio's feeder): the
    error its iterable raised, if any, handed to the reading side."""

    error: Optional[BaseException]


def raise_feeder_error(feeder: FeederError, failed: Optional[SquallError]) -> None:
    """Raises the error `feeder`'s iterable raised, if any, once: from `failed`, the server's
    status, when the call failed too.

    The iterable's error is the one raised, as the caller's own; but when the server had failed a
    message before it, that status (e.g. INVALID_ARGUMENT naming "Run message 3") says why the
    call ended, and is kept as the error's __cause__ rather than dropped."""
    error, feeder.error = feeder.error, None
    if error is None:
        return
    if failed is None:
        raise error
    raise error from failed


_END = object()


class RequestQueue(Iterator[Any]):
    """The request side of a bidirectional call: put() one message at a time, close() to end."""

    def __init__(self) -> None:
        self._queue: "queue.Queue[Any]" = queue.Queue()
        self._closed = threading.Event()

    def put(self, message: Any) -> None:
        if self._closed.is_set():
            raise RuntimeError("the stream's request side is closed")
        self._queue.put(message)

    def close(self) -> None:
        if not self._closed.is_set():
            self._closed.set()
            self._queue.put(_END)

    def __iter__(self) -> "RequestQueue":
        return self

    def __next__(self) -> Any:
        item = self._queue.get()
        if item is _END:
            raise StopIteration
        return item


class RequestFeeder(Iterator[Any]):
    """The request side of a bidirectional call from an iterable, each item converted with its
    index.

    gRPC reads it on its own thread, as soon as the previous request is written; the feeder makes
    that thread wait until the Stream reading the replies has returned one more (``taken``), so at
    most `ahead` items are read beyond the replies taken. An exception raised by the iterable or
    the conversion ends the request side (the call finishes what it was sent) and is raised again
    by the Stream, instead of surfacing as a bare CANCELLED (from the server's SquallError when
    the call failed too: raise_feeder_error).
    """

    def __init__(
        self, items: Iterable[Any], convert: Callable[[Any, int], Any], ahead: int = RUN_AHEAD
    ) -> None:
        self._items = iter(items)
        self._convert = convert
        self._index = 0
        self._window = threading.Semaphore(ahead)
        self._closed = False
        self.error: Optional[BaseException] = None

    def taken(self) -> None:
        """The caller took one reply: one more item may be read."""
        self._window.release()

    def close(self) -> None:
        """The call has ended: no more items are read, and gRPC's thread stops waiting."""
        self._closed = True
        self._window.release()

    def __iter__(self) -> "RequestFeeder":
        return self

    def __next__(self) -> Any:
        self._window.acquire()
        if self._closed or self.error is not None:
            raise StopIteration
        try:
            item = next(self._items)
            message = self._convert(item, self._index)
        except StopIteration:
            raise
        except Exception as error:  # handed to the reading side
            self.error = error
            raise StopIteration from None
        self._index += 1
        return message

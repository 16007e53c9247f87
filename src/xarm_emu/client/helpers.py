"""The client methods, written once for both twins.

A typed helper is a generator: it yields the :class:`Call` it needs (one register request each) and
receives the decoded :class:`~.common.Response`, then returns its typed value. :func:`helper`
wraps it in a :class:`Helper`, a descriptor that gives the sync :class:`~.sync.Client` a plain
method and the :class:`~.aio.AsyncClient` a coroutine method with the same parameters and return
annotation, both driving the same generator. :class:`Helpers` holds the helpers; both clients
inherit it, and :func:`add_register_methods` adds one method per register of the table
(``move_line``, ``get_tcp_pose``, ...) in the same way.
"""

from __future__ import annotations

import inspect
import typing
from collections.abc import Awaitable, Callable, Generator
from dataclasses import dataclass, field
from typing import Any, Generic, ParamSpec, Protocol, TypeVar, overload

from ..protocol import registers as regs
from .common import Response, method_name

P = ParamSpec("P")
T = TypeVar("T")


@dataclass(frozen=True)
class Call:
    """One request a helper needs: a register (code or name), and its values or raw parameters."""

    register: int | str
    values: dict[str, Any] = field(default_factory=dict)
    raw: bytes | None = None


#: What a helper generator is: it yields calls, receives their responses and returns its value.
Exchange = Generator[Call, Response, T]


def _run_sync(client: Any, exchange: Exchange[T]) -> T:
    try:
        call = next(exchange)
        while True:
            call = exchange.send(client.call(call.register, call.raw, **call.values))
    except StopIteration as done:
        return typing.cast(T, done.value)


async def _run_async(client: Any, exchange: Exchange[T]) -> T:
    try:
        call = next(exchange)
        while True:
            call = exchange.send(await client.call(call.register, call.raw, **call.values))
    except StopIteration as done:
        return typing.cast(T, done.value)


class SyncCaller(Protocol):
    """A client whose ``call`` answers at once (:class:`~.sync.Client`)."""

    def call(self, register: int | str, raw: bytes | None = None, **values: Any) -> Response: ...


class AsyncCaller(Protocol):
    """A client whose ``call`` is a coroutine (:class:`~.aio.AsyncClient`)."""

    async def call(self, register: int | str, raw: bytes | None = None, **values: Any) -> Response: ...


class Helper(Generic[P, T]):
    """A client method defined once: a plain method on classes whose ``call`` is a plain function,
    a coroutine method on classes whose ``call`` is a coroutine function."""

    def __init__(self, exchange: Callable[P, Exchange[T]], name: str | None = None,
                 doc: str | None = None, returns: Any = None) -> None:
        self.exchange = exchange
        self.name = name or exchange.__name__
        self.doc = doc if doc is not None else exchange.__doc__
        sig = inspect.signature(exchange)
        if returns is None:
            returns = typing.get_args(typing.get_type_hints(exchange)["return"])[2]
        self_param = inspect.Parameter("self", inspect.Parameter.POSITIONAL_OR_KEYWORD)
        self.signature = sig.replace(parameters=[self_param, *sig.parameters.values()],
                                     return_annotation=returns)
        self._methods: dict[bool, Callable[..., Any]] = {}

    def __set_name__(self, owner: type, name: str) -> None:
        self.name = name

    def method(self, asynchronous: bool) -> Callable[..., Any]:
        """The concrete function for a sync (False) or async (True) client class."""
        if asynchronous not in self._methods:
            exchange = self.exchange
            if asynchronous:
                async def amethod(client: Any, *args: Any, **kwargs: Any) -> Any:
                    return await _run_async(client, exchange(*args, **kwargs))

                fn: Any = amethod
            else:
                def smethod(client: Any, *args: Any, **kwargs: Any) -> Any:
                    return _run_sync(client, exchange(*args, **kwargs))

                fn = smethod
            fn.__name__ = fn.__qualname__ = self.name
            fn.__doc__ = self.doc
            fn.__signature__ = self.signature
            self._methods[asynchronous] = fn
        return self._methods[asynchronous]

    @overload
    def __get__(self, obj: None, owner: type) -> Callable[..., Any]: ...

    @overload
    def __get__(self, obj: SyncCaller, owner: type) -> Callable[P, T]: ...

    @overload
    def __get__(self, obj: AsyncCaller, owner: type) -> Callable[P, Awaitable[T]]: ...

    def __get__(self, obj: Any, owner: type) -> Any:
        fn = self.method(inspect.iscoroutinefunction(owner.call))  # type: ignore[attr-defined]
        return fn if obj is None else fn.__get__(obj, owner)


def helper(exchange: Callable[P, Exchange[T]]) -> Helper[P, T]:
    """Decorator: a generator of :class:`Call` s becomes a method of both clients."""
    return Helper(exchange)


class Helpers:
    """The typed helpers of both clients (registers of manual section 2.1.3)."""

    @helper
    def get_version() -> Exchange[str]:
        """Register 1: the version string (``"<axis>,<type>,..."``)."""
        r = yield Call(1)
        return str(r["version"])

    @helper
    def get_state() -> Exchange[int]:
        """Register 13: the motion state (1 moving, 2 sleeping, 3 suspended, 4 stopped)."""
        r = yield Call(13)
        return int(r["state"])

    @helper
    def get_cmdnum() -> Exchange[int]:
        """Register 14: the number of commands in the buffer."""
        r = yield Call(14)
        return int(r["cmdnum"])

    @helper
    def get_err_warn() -> Exchange[tuple[int, int]]:
        """Register 15: ``(error, warning)`` codes."""
        r = yield Call(15)
        return int(r["error"]), int(r["warning"])

    @helper
    def get_position() -> Exchange[tuple[float, ...]]:
        """Register 41: the TCP pose (x, y, z mm; roll, pitch, yaw rad)."""
        r = yield Call(41)
        return tuple(r["pose"])

    @helper
    def get_joints() -> Exchange[tuple[float, ...]]:
        """Register 42: the joint angles J1..J7 in rad."""
        r = yield Call(42)
        return tuple(r["joints"])

    @helper
    def motion_enable(enable: bool = True, joint: int = 8) -> Exchange[Response]:
        """Register 11: enable (or disable) one joint, or all with ``joint=8`` (a system reset)."""
        return (yield Call(11, {"joint": joint, "enable": int(enable)}))

    @helper
    def set_mode(mode: int) -> Exchange[Response]:
        """Register 19: the control mode (0 position, 1 servo, 2 joint teach, ...)."""
        return (yield Call(19, {"mode": mode}))

    @helper
    def set_state(state: int) -> Exchange[Response]:
        """Register 12: the motion state (0 start, 3 suspend, 4 stop)."""
        return (yield Call(12, {"state": state}))

    @helper
    def clean_error() -> Exchange[Response]:
        """Register 16: clear the error code."""
        return (yield Call(16))

    @helper
    def clean_warn() -> Exchange[Response]:
        """Register 17: clear the warning code."""
        return (yield Call(17))


def _register_doc(reg: regs.Register) -> str:
    return (f"Register {reg.code}, {reg.title} (manual {reg.section}).\n\n"
            f"Request: {reg.request.describe()}\nReply: {reg.reply.describe()}\n"
            + (f"\n{reg.doc}\n" if reg.doc else ""))


def _register_helper(reg: regs.Register) -> Helper[..., Response]:
    code = reg.code

    def exchange(raw: bytes | None = None, **values: Any) -> Exchange[Response]:
        return (yield Call(code, values, raw))

    return Helper(exchange, method_name(reg), _register_doc(reg), returns=Response)


def add_register_methods(cls: type) -> None:
    """Give ``cls`` one method per register of the table (keyword arguments are the request's
    fields, ``raw`` bypasses the layout; the result is a :class:`Response` whose ``values`` are
    the reply's fields), unless the class already has a method of that name (a typed helper)."""
    for reg in regs.REGISTERS.values():
        name = method_name(reg)
        if not hasattr(cls, name):
            setattr(cls, name, _register_helper(reg))

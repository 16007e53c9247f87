"""The state tree (:class:`~xarm_emu.controller.box_state.EmulatorState`) as bytes and back: what a
checkpoint file holds, loadable by another process (an emulator feature; no real control box has
checkpoints).

The bytes are MessagePack written and read by msgspec: a binary format whose floats are IEEE
doubles bit for bit (a resumed motion must continue exactly), compact and fast, and msgspec is
the project's serialiser of recordings already. The tree is first turned into plain values
(maps, lists, numbers, strings, bytes), each of its objects as a small map that names its kind:

========  ===============================================================================
``t``     a tuple; ``q`` a deque (``m``: its maxlen); ``d`` a dict as (key, value) pairs;
          ``s``/``fs`` a set/frozenset; ``L`` a list that is referred to more than once
``a``     a numpy array (``d``: dtype, ``s``: shape, ``b``: its bytes, ``w``: writeable);
          ``g`` a numpy scalar; ``P`` a file system path (a trajectory store's directory)
``c``     a dataclass (``c``: ``module:QualName``, ``f``: its fields); ``o`` any other object
          of the emulator by its attributes; ``e`` an enum member
``R``     an object rebuilt by calling ``f`` with ``a`` (its ``__reduce__``): a planned motion
          keeps the inputs it was planned from and is planned again on load (ruckig's
          trajectories are not data; planning them is deterministic)
``r``     one of the fixed objects the tree refers to (``n``: the model, the controller, the
          emulator, its components); ``m`` a method of one of them, ``M`` of an object of the
          tree (``s``); ``f`` a module-level function or class of the emulator; ``p`` a
          ``functools.partial`` (a task waiting in the command buffer)
``@``     an object met before (``#``: the number the first one carried)
========  ===============================================================================

An object referred to from more than one place carries a number (``#``) and comes back as one
object: the executor hands the plan's last joints back as the next start, and identity is what
tells the plan its own answer. The type annotations of the tree are not used to read it (some
name classes that the state module imports for type checking only, and a device field is a
union of dataclasses), so every object names its class; reading imports only classes and
functions of this package. A value that has no such form (a lambda among the scheduled actions)
is refused with :class:`StateBytesError` naming where it is.
"""

from __future__ import annotations

import dataclasses
import enum
import functools
import importlib
import types
from collections import Counter, deque
from collections.abc import Mapping
from pathlib import Path, PurePath
from typing import Any

import msgspec
import numpy as np

#: What the first map of the bytes says, so that other files are refused clearly.
FORMAT = "xarm-emu state"
VERSION = 1
_PACKAGE = __name__.split(".")[0]
_ATOMS = (type(None), bool, int, float, str, bytes)


class StateBytesError(ValueError):
    """The state cannot be written as bytes, or the bytes are not a state this emulator can read."""


def _path(obj: Any) -> str:
    return f"{obj.__module__}:{obj.__qualname__}"


def _ours(obj: Any) -> bool:
    return (getattr(obj, "__module__", None) or "").split(".")[0] == _PACKAGE


def _attributes(obj: object) -> dict[str, Any]:
    """An object's own attributes: its ``__dict__`` and every slot that is set."""
    out = dict(getattr(obj, "__dict__", {}))
    for cls in type(obj).__mro__:
        for name in getattr(cls, "__slots__", ()):
            if name not in ("__dict__", "__weakref__") and hasattr(obj, name):
                out[name] = getattr(obj, name)
    return out


def _custom_reduce(obj: object) -> bool:
    return type(obj).__reduce__ is not object.__reduce__ and _ours(type(obj))


class _Writer:
    def __init__(self, shared: Mapping[str, object], refs: Counter[int],
                 reduced: dict[int, tuple[Any, tuple[Any, ...]]]) -> None:
        self.shared = {id(v): k for k, v in shared.items()}
        self.refs = refs  # how often each object is referred to in the tree
        self.reduced = reduced  # (call, args) of the objects rebuilt by a call, made once
        self.numbers: dict[int, int] = {}

    def value(self, obj: Any, where: str) -> Any:
        if type(obj) in _ATOMS:
            return obj
        key = id(obj)
        name = self.shared.get(key)
        if name is not None:
            return {"~": "r", "n": name}
        if key in self.numbers:
            return {"~": "@", "#": self.numbers[key]}
        node = self._node(obj, where)
        if self.refs[key] > 1 and isinstance(node, dict):
            self.numbers[key] = len(self.numbers)
            node["#"] = self.numbers[key]
        return node

    def _many(self, items: Any, where: str) -> list[Any]:
        return [self.value(x, f"{where}[{i}]") for i, x in enumerate(items)]

    def _node(self, obj: Any, where: str) -> Any:  # noqa: PLR0911 - one return per kind of node
        if isinstance(obj, list):
            items = self._many(obj, where)
            return {"~": "L", "v": items} if self.refs[id(obj)] > 1 else items
        if isinstance(obj, tuple):
            return {"~": "t", "v": self._many(obj, where)}
        if isinstance(obj, deque):
            return {"~": "q", "v": self._many(obj, where), "m": obj.maxlen}
        if isinstance(obj, dict):
            return {"~": "d", "v": [[self.value(k, where), self.value(v, f"{where}[{k!r}]")]
                                    for k, v in obj.items()]}
        if isinstance(obj, (set, frozenset)):
            return {"~": "s" if isinstance(obj, set) else "fs", "v": self._many(obj, where)}
        if isinstance(obj, np.ndarray):
            if obj.dtype.hasobject:
                raise StateBytesError(f"{where}: an array of Python objects cannot be written")
            return {"~": "a", "d": obj.dtype.str, "s": list(obj.shape),
                    "b": np.ascontiguousarray(obj).tobytes(), "w": bool(obj.flags.writeable)}
        if isinstance(obj, np.generic):
            return {"~": "g", "d": obj.dtype.str, "b": obj.tobytes()}
        if isinstance(obj, PurePath):
            return {"~": "P", "v": str(obj)}
        if isinstance(obj, enum.Enum):
            return {"~": "e", "c": _path(type(obj)), "v": self.value(obj.value, where)}
        if isinstance(obj, types.MethodType):
            if id(obj.__self__) in self.shared:
                return {"~": "m", "n": self.shared[id(obj.__self__)], "a": obj.__func__.__name__}
            return {"~": "M", "s": self.value(obj.__self__, where), "a": obj.__func__.__name__}
        if isinstance(obj, functools.partial):
            return {"~": "p", "f": self.value(obj.func, where), "a": self.value(obj.args, where),
                    "k": self.value(obj.keywords, where)}
        if isinstance(obj, types.FunctionType):
            if not _ours(obj) or "<" in obj.__qualname__:
                raise StateBytesError(f"{where}: {obj.__qualname__} (a function made at run time, such "
                                      "as a lambda among the scheduled actions) cannot be written")
            return {"~": "f", "c": _path(obj)}
        if isinstance(obj, type) and _ours(obj):
            return {"~": "f", "c": _path(obj)}
        if not _ours(type(obj)):
            raise StateBytesError(f"{where}: a {type(obj).__qualname__} cannot be written")
        if dataclasses.is_dataclass(obj):
            return {"~": "c", "c": _path(type(obj)),
                    "f": {f.name: self.value(getattr(obj, f.name), f"{where}.{f.name}")
                          for f in dataclasses.fields(obj) if hasattr(obj, f.name)}}
        if _custom_reduce(obj):
            call, args = self.reduced[id(obj)]
            return {"~": "R", "f": self.value(call, where), "a": self.value(args, where)}
        return {"~": "o", "c": _path(type(obj)),
                "f": {k: self.value(v, f"{where}.{k}") for k, v in _attributes(obj).items()}}


def _count(root: object, shared: Mapping[str, object],
           reduced: dict[int, tuple[Any, tuple[Any, ...]]]) -> Counter[int]:
    """How often each object under ``root`` is referred to (shared objects are not entered); the
    (call, args) of each object rebuilt by a call go into ``reduced`` (made once, so that the
    objects in them stay alive and keep their ids while the tree is written)."""
    refs: Counter[int] = Counter()
    stop = {id(v) for v in shared.values()}
    stack = [root]
    while stack:
        obj = stack.pop()
        if type(obj) in _ATOMS or id(obj) in stop:
            continue
        refs[id(obj)] += 1
        if refs[id(obj)] > 1:
            continue
        if isinstance(obj, dict):
            stack.extend(obj.keys())
            stack.extend(obj.values())
        elif isinstance(obj, (list, tuple, deque, set, frozenset)):
            stack.extend(obj)
        elif isinstance(obj, types.MethodType):
            stack.append(obj.__self__)
        elif isinstance(obj, (np.ndarray, np.generic, enum.Enum, types.FunctionType, type, PurePath)):
            continue
        elif isinstance(obj, functools.partial):
            stack.extend((obj.func, obj.args, obj.keywords))
        elif dataclasses.is_dataclass(obj):
            stack.extend(getattr(obj, f.name) for f in dataclasses.fields(obj) if hasattr(obj, f.name))
        elif _custom_reduce(obj):
            made: Any = obj.__reduce__()
            made = reduced[id(obj)] = (made[0], made[1])
            stack.append(made[1])
        else:
            stack.extend(_attributes(obj).values())
    return refs


def encode(state: object, shared: Mapping[str, object], meta: Mapping[str, Any] | None = None) -> bytes:
    """``state`` as bytes. ``shared``: the fixed objects the tree may refer to, by name (written as
    the name, given again to :func:`decode`); ``meta``: plain values written beside it (what box
    it is), read back by :func:`decode`. Raises :class:`StateBytesError` for a value that has no
    written form."""
    reduced: dict[int, tuple[Any, tuple[Any, ...]]] = {}
    writer = _Writer(shared, _count(state, shared, reduced), reduced)
    return msgspec.msgpack.encode({"format": FORMAT, "version": VERSION, "meta": dict(meta or {}),
                                   "state": writer.value(state, "state")})


def _resolve(path: Any) -> Any:
    """The class or function ``module:QualName`` of this package (nothing else is imported)."""
    if not isinstance(path, str) or ":" not in path:
        raise StateBytesError(f"not a class name: {path!r}")
    module, _, qualname = path.partition(":")
    if module.split(".")[0] != _PACKAGE:
        raise StateBytesError(f"{path}: not a class of this emulator")
    try:
        obj: Any = importlib.import_module(module)
        for part in qualname.split("."):
            obj = getattr(obj, part)
    except (ImportError, AttributeError) as exc:
        raise StateBytesError(f"{path}: no such class in this version of the emulator") from exc
    return obj


#: What MessagePack reads as itself (a list or a map is a node to read further).
_PLAIN = frozenset(_ATOMS)


class _Reader:
    def __init__(self, shared: Mapping[str, object]) -> None:
        self.shared = shared
        self.numbered: dict[int, Any] = {}

    def value(self, node: Any) -> Any:
        if isinstance(node, list):  # most items are plain numbers: taken as they are
            return [x if type(x) in _PLAIN else self.value(x) for x in node]
        if not isinstance(node, dict):
            return node
        kind = node.get("~")
        if kind == "@":
            return self.numbered[node["#"]]
        if kind == "r":
            return self._shared(node["n"])
        number = node.get("#")
        if kind in ("L", "c", "o"):  # containers that may refer to themselves: registered first
            if kind == "L":
                out: Any = []
                self._number(number, out)
                out.extend(self.value(x) for x in node["v"])
                return out
            cls: Any = _resolve(node["c"])
            if not isinstance(cls, type):
                raise StateBytesError(f"{node['c']}: not a class")
            out = object.__new__(cls)
            self._number(number, out)
            for name, v in node["f"].items():
                object.__setattr__(out, name, self.value(v))
            return out
        out = self._leaf(kind, node)
        self._number(number, out)
        return out

    def _shared(self, name: Any) -> object:
        if name not in self.shared:  # a fault schedule's server, say, in a box served without one
            raise StateBytesError(f"the saved state refers to the {name!r} of its box, which this "
                                  "emulator does not have")
        return self.shared[name]

    def _number(self, number: int | None, obj: Any) -> None:
        if number is not None:
            self.numbered[number] = obj

    def _leaf(self, kind: Any, node: dict[str, Any]) -> Any:  # noqa: PLR0911 - one return per kind
        if kind == "t":
            return tuple(self.value(x) for x in node["v"])
        if kind == "q":
            return deque((self.value(x) for x in node["v"]), node["m"])
        if kind == "d":
            return {self.value(k): self.value(v) for k, v in node["v"]}
        if kind in ("s", "fs"):
            return (set if kind == "s" else frozenset)(self.value(x) for x in node["v"])
        if kind == "a":
            arr = np.frombuffer(node["b"], dtype=np.dtype(node["d"])).reshape(node["s"]).copy()
            arr.flags.writeable = bool(node["w"])
            return arr
        if kind == "g":
            return np.frombuffer(node["b"], dtype=np.dtype(node["d"]))[0]
        if kind == "P":
            return Path(node["v"])
        if kind == "e":
            return _resolve(node["c"])(self.value(node["v"]))
        if kind == "m":
            return getattr(self._shared(node["n"]), node["a"])
        if kind == "M":
            return getattr(self.value(node["s"]), node["a"])
        if kind == "f":
            return _resolve(node["c"])
        if kind == "p":
            return functools.partial(self.value(node["f"]), *self.value(node["a"]), **self.value(node["k"]))
        if kind == "R":
            call = self.value(node["f"])
            if not _ours(call):
                raise StateBytesError(f"{call!r}: not a function of this emulator")
            return call(*self.value(node["a"]))
        raise StateBytesError(f"unknown kind of value {kind!r}")


def decode(data: bytes, shared: Mapping[str, object]) -> tuple[Any, dict[str, Any]]:
    """The state and the meta values that :func:`encode` wrote in ``data``; ``shared``: the fixed
    objects by the names given to :func:`encode`. Raises :class:`StateBytesError` for bytes that
    are not such a state."""
    try:
        top = msgspec.msgpack.decode(data)
    except msgspec.DecodeError as exc:
        raise StateBytesError(f"not a saved emulator state ({exc})") from exc
    if not isinstance(top, dict) or top.get("format") != FORMAT:
        raise StateBytesError("not a saved emulator state")
    if top.get("version") != VERSION:
        raise StateBytesError(f"a saved state of format version {top.get('version')!r}; this emulator "
                              f"reads version {VERSION}")
    try:
        state = _Reader(shared).value(top["state"])
    except (KeyError, TypeError, ValueError) as exc:
        if isinstance(exc, StateBytesError):
            raise
        raise StateBytesError(f"a damaged saved state ({type(exc).__name__}: {exc})") from exc
    meta = top.get("meta")
    return state, meta if isinstance(meta, dict) else {}


__all__ = ["FORMAT", "VERSION", "StateBytesError", "decode", "encode"]

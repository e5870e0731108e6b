"""The checkpoint file of a running case: data only, nothing in it can run code on load.

One zip file (stored, not compressed) of three kinds of member, written in this order:

- ``header.json``: ``{"format": "millsim-checkpoint", "version": 1, ...}`` and what the caller
  puts beside it (scene, parameters, software versions, engine hash). :func:`read` hands it to
  the caller's check before it looks at anything else;
- ``arrays/<n>.npy``: every numpy array of the state, in numpy's .npy format (object arrays are
  refused on writing, and read with ``allow_pickle=False``);
- ``state.json``: the object graph as a JSON tree (below).

The tree: None, bool, int, float and str are themselves; everything else is a JSON object tagged
by ``"t"``, with an ``"id"`` where identity matters, and ``{"ref": id}`` for each later
occurrence, so that shared references and cycles (``model.sim -> sim -> model``) come back as
they were. Lists, tuples, dicts (any encodable keys, kept in order), numpy arrays, numpy
scalars, numpy Generators (their bit generator's state) and instances of millsim's classes:
``{"t": "object", "class": "millsim.engine.module:Qualname", "state": ...}``, the state being
what ``__getstate__`` returns (the instance's ``__dict__`` by default), rebuilt as pickle does,
with ``cls.__new__(cls)`` and then ``__setstate__`` or an update of ``__dict__``, the object
existing before its state is read so that a cycle through it resolves; namedtuples from their
items. Classes held as values are stored by name, bound methods as their object and the name of
a function of its class. A name is looked up only in millsim's engine, models, scenes and util
(the layers a case's state is made of) and must name a class defined there; anything else is
refused, so a planted file can at most describe millsim objects, and nothing in it is called.

Anything else the writer meets is a TypeError naming its type and where it was (``case.sim.x``):
supporting it is a decision, not a fallback.
"""

import importlib
import json
import os
import sys
import types
import zipfile
from collections.abc import Callable
from typing import Any

import numpy as np

FORMAT = "millsim-checkpoint"
VERSION = 1
HEADER, STATE = "header.json", "state.json"
_HEADER_MAX_BYTES = 1 << 20  # a header is a few kB; a larger one is no header of ours
# the bit generators numpy ships; the name in a file is looked up only among these
_BIT_GENERATORS = {name: getattr(np.random, name)
                   for name in ("PCG64", "PCG64DXSM", "MT19937", "Philox", "SFC64")}
_ATOMS = (type(None), bool, int, float, str)
# where the classes of a case's state live: the layers a scene is built from (not the command
# line, the studies or the writers, whose methods act on files)
_PACKAGES = [["millsim", part] for part in ("engine", "models", "scenes", "util")]


def write(path: str | os.PathLike[str], header: dict[str, Any], state: Any,
          packages: tuple[str, ...] = ()) -> None:
    """Write ``state`` to a new checkpoint file at ``path`` under ``header`` (JSON values) and
    flush it to disk (an atomic rename of it must not land before its data). ``packages``: the
    top-level packages outside millsim whose classes the state may hold (a user's scene)."""
    with open(path, "wb") as fh:
        with zipfile.ZipFile(fh, "w", zipfile.ZIP_STORED) as zf:
            zf.writestr(HEADER, json.dumps({"format": FORMAT, "version": VERSION, **header}))
            tree = _Writer(zf, _Names(packages)).encode(state, "state")
            zf.writestr(STATE, json.dumps(tree, separators=(",", ":")))
        fh.flush()
        os.fsync(fh.fileno())


def read(path: str | os.PathLike[str], check: Callable[[dict[str, Any]], None],
         packages: tuple[str, ...] = ()) -> Any:
    """The state of the checkpoint at ``path``, after ``check(header)`` (which raises to refuse it)
    has passed (``packages`` as for :func:`write`). ValueError "not a checkpoint (...)" for a file
    that is none of ours, whatever ``check`` raises for a foreign header, and ValueError
    "unreadable (...)" for a damaged state."""
    try:
        zf = zipfile.ZipFile(path)
    except (zipfile.BadZipFile, zipfile.LargeZipFile, EOFError) as exc:
        raise ValueError(f"not a checkpoint ({exc})") from None
    with zf:
        header = _read_header(zf)
        check(header)
        try:
            return _Reader(zf, _Names(packages)).decode(json.loads(zf.read(STATE)))
        except Exception as exc:  # past the header: a damaged file, or one made to pass it
            if isinstance(exc, ValueError) and str(exc).startswith("not a checkpoint"):
                raise
            raise ValueError(f"unreadable ({type(exc).__name__}: {exc})") from None


def _read_header(zf: zipfile.ZipFile) -> dict[str, Any]:
    try:
        info = zf.getinfo(HEADER)
    except KeyError:
        raise ValueError("not a checkpoint (no header)") from None
    if info.file_size > _HEADER_MAX_BYTES:
        raise ValueError(f"not a checkpoint (a header of {info.file_size} bytes)")
    try:
        header = json.loads(zf.read(info))
    except Exception as exc:  # whatever a damaged or made-up member raises (zlib, zipfile, json)
        raise ValueError(f"not a checkpoint (header: {exc})") from None
    if not isinstance(header, dict) or header.get("format") != FORMAT:
        raise ValueError("not a checkpoint (no header)")
    if header.get("version") != VERSION:
        raise ValueError(f"not a checkpoint of this version (format version "
                         f"{header.get('version')!r}, this millsim reads {VERSION})")
    return header


class _Names:
    """Where the classes named in a checkpoint may come from: millsim's layers below the studies
    (imported on demand) and the top-level ``packages`` of a scene from outside millsim (a
    ``--scene-module`` or a plugin: the user's own code, only looked up in what is imported)."""

    def __init__(self, packages: tuple[str, ...]):
        self.packages = packages

    def allowed(self, module: Any) -> bool:
        parts = module.split(".") if isinstance(module, str) else [""]
        return (parts[:2] in _PACKAGES or parts[0] in self.packages) and \
            all(p.isidentifier() for p in parts)

    def resolve(self, name: Any) -> type:
        """The class named ``module:qualname``, defined in an allowed module."""
        if not isinstance(name, str) or name.count(":") != 1:
            raise ValueError(f"not a checkpoint (class name {name!r})")
        module, qualname = name.split(":")
        if not self.allowed(module) or not all(p.isidentifier() for p in qualname.split(".")):
            raise ValueError(f"not a checkpoint (class {name} is not millsim's)")
        try:
            obj = importlib.import_module(module) if module.startswith("millsim.") else \
                sys.modules[module]
            for attr in qualname.split("."):
                obj = getattr(obj, attr)
        except (ImportError, KeyError, AttributeError):
            raise ValueError(f"not a checkpoint (no class {name} in this millsim)") from None
        if not isinstance(obj, type) or (obj.__module__, obj.__qualname__) != (module, qualname):
            raise ValueError(f"not a checkpoint ({name} is no class defined in millsim)")
        return obj

    def name_of(self, cls: type) -> str | None:
        """``module:qualname`` of a class that :meth:`resolve` gives back, else None."""
        module, qualname = getattr(cls, "__module__", None), getattr(cls, "__qualname__", None)
        if not isinstance(module, str) or not isinstance(qualname, str):
            return None
        name = f"{module}:{qualname}"
        try:
            return name if self.resolve(name) is cls else None
        except ValueError:
            return None


def _custom(cls: type, method: str) -> bool:
    return getattr(cls, method, None) is not getattr(object, method, None)


class _Writer:
    def __init__(self, zf: zipfile.ZipFile, names: _Names):
        self.zf, self.names = zf, names
        # id -> (tree id, the object): holding the object keeps a temporary (a __getstate__
        # result) alive, so that its id is not reused by another within this checkpoint
        self.memo: dict[int, tuple[int, Any]] = {}
        self.building: set[int] = set()  # tuples whose items are being encoded
        self.arrays = 0

    def _remember(self, obj: Any) -> int:
        ref = len(self.memo)
        self.memo[id(obj)] = (ref, obj)
        return ref

    def encode(self, obj: Any, path: str) -> Any:
        cls = type(obj)
        if cls in _ATOMS:
            return obj
        if id(obj) in self.memo:
            if id(obj) in self.building:
                raise TypeError(f"checkpoint: {path} is a tuple that contains itself")
            return {"ref": self.memo[id(obj)][0]}
        if cls.__module__.split(".")[0] == "numba":
            raise TypeError(f"checkpoint: {path} is {cls.__name__} {obj!r:.60}, compiled code is "
                            "rebuilt on load, never saved; drop it in its owner's __getstate__")
        if isinstance(obj, np.generic):
            if obj.dtype.kind not in "biuf":
                raise TypeError(f"checkpoint: {path} is a numpy {cls.__name__}, not supported")
            return {"t": "scalar", "dtype": obj.dtype.str, "value": obj.item()}
        if cls is list:
            node = {"t": "list", "id": self._remember(obj)}
            node["items"] = [self.encode(v, f"{path}[{k}]") for k, v in enumerate(obj)]
            return node
        if cls is dict:
            node = {"t": "dict", "id": self._remember(obj)}
            node["items"] = [[self.encode(k, f"{path} key {k!r:.40}"),
                              self.encode(v, f"{path}[{k!r:.40}]")] for k, v in obj.items()]
            return node
        if cls is tuple:
            node = {"t": "tuple", "id": self._remember(obj)}
            self.building.add(id(obj))
            node["items"] = [self.encode(v, f"{path}[{k}]") for k, v in enumerate(obj)]
            self.building.discard(id(obj))
            return node
        if cls is np.ndarray:
            return self._array(obj, path)
        if cls is np.random.Generator:
            bits = obj.bit_generator
            if type(bits) not in _BIT_GENERATORS.values():
                raise TypeError(f"checkpoint: {path} draws from {type(bits).__name__}, not "
                                "supported")
            # what the draws depend on; the seed sequence (for spawn) is not kept: no case spawns
            node = {"t": "generator", "id": self._remember(obj)}
            node["state"] = self.encode(bits.state, f"{path}.bit_generator.state")
            return node
        if cls is types.MethodType:
            owner, func = obj.__self__, obj.__func__
            if getattr(type(owner), func.__name__, None) is not func:
                raise TypeError(f"checkpoint: {path} is {obj!r:.60}, not a method of its object's "
                                "class")
            return {"t": "method", "self": self.encode(owner, f"{path}.__self__"),
                    "name": func.__name__}
        if isinstance(obj, type):
            name = self.names.name_of(obj)
            if name is None:
                raise TypeError(f"checkpoint: {path} is the class {obj.__module__}."
                                f"{obj.__qualname__}, not one defined in millsim")
            return {"t": "class", "name": name}
        name = self.names.name_of(cls)
        if name is None:
            raise TypeError(f"checkpoint: {path} is {cls.__module__}.{cls.__qualname__}, which "
                            "a checkpoint does not store")
        if issubclass(cls, (list, dict, set, frozenset, np.ndarray)) or \
                issubclass(cls, tuple) and not hasattr(cls, "_fields"):
            raise TypeError(f"checkpoint: {path} is {name}, a subclass of a container, not "
                            "supported")
        if issubclass(cls, tuple):  # a namedtuple: rebuilt from its items
            node = {"t": "namedtuple", "class": name, "id": self._remember(obj)}
            self.building.add(id(obj))
            node["items"] = [self.encode(v, f"{path}.{f}") for f, v in zip(cls._fields, obj)]
            self.building.discard(id(obj))
            return node
        node = {"t": "object", "class": name, "id": self._remember(obj)}
        state = obj.__getstate__() if _custom(cls, "__getstate__") else obj.__dict__
        if type(state) is dict:  # attribute paths read better than dict keys
            node["state"] = {"t": "dict", "id": self._remember(state), "items": [
                [self.encode(k, f"{path} key {k!r:.40}"), self.encode(v, f"{path}.{k}")]
                for k, v in state.items()]}
        else:
            node["state"] = self.encode(state, f"{path} state")
        return node

    def _array(self, obj: np.ndarray, path: str) -> dict[str, Any]:
        if obj.dtype.hasobject:
            raise TypeError(f"checkpoint: {path} is an array of Python objects, not supported")
        member = f"arrays/{self.arrays}.npy"
        self.arrays += 1
        # zip64 from the start: the size of a member written as a stream is known only after it
        with self.zf.open(member, "w", force_zip64=obj.nbytes > 1 << 30) as fh:
            np.lib.format.write_array(fh, obj, allow_pickle=False)
        return {"t": "array", "id": self._remember(obj), "member": member}


class _Reader:
    def __init__(self, zf: zipfile.ZipFile, names: _Names):
        self.zf, self.names = zf, names
        self.memo: dict[int, Any] = {}

    def _remember(self, node: dict[str, Any], obj: Any) -> Any:
        ref = node["id"]
        if type(ref) is not int or ref in self.memo:
            raise ValueError(f"not a checkpoint (id {ref!r})")
        self.memo[ref] = obj
        return obj

    def decode(self, node: Any) -> Any:
        if type(node) in _ATOMS:
            return node
        if type(node) is not dict:
            raise ValueError(f"not a checkpoint (a {type(node).__name__} in the state)")
        if "ref" in node:
            if node["ref"] not in self.memo:
                raise ValueError(f"not a checkpoint (reference {node['ref']!r} before its object)")
            return self.memo[node["ref"]]
        kind = node.get("t")
        if kind == "list":
            obj = self._remember(node, [])
            obj.extend(self.decode(v) for v in node["items"])
            return obj
        if kind == "dict":
            obj = self._remember(node, {})
            for k, v in node["items"]:
                obj[self.decode(k)] = self.decode(v)
            return obj
        if kind == "tuple":
            return self._remember(node, tuple(self.decode(v) for v in node["items"]))
        if kind == "scalar":
            dtype = np.dtype(node["dtype"])
            if dtype.kind not in "biuf":
                raise ValueError(f"not a checkpoint (scalar of dtype {dtype})")
            return dtype.type(node["value"])
        if kind == "array":
            with self.zf.open(node["member"]) as fh:
                return self._remember(node, np.lib.format.read_array(fh, allow_pickle=False))
        if kind == "generator":
            state = self.decode(node["state"])
            bits = _BIT_GENERATORS.get(state.get("bit_generator") if type(state) is dict else None)
            if bits is None:
                raise ValueError("not a checkpoint (a generator of no known bit generator)")
            obj = np.random.Generator(bits())
            obj.bit_generator.state = state
            return self._remember(node, obj)
        if kind == "class":
            return self.names.resolve(node["name"])
        if kind == "method":
            owner, name = self.decode(node["self"]), node["name"]
            func = getattr(type(owner), name, None) if isinstance(name, str) else None
            # only a function of the object's own (millsim) class, bound without calling anything
            if type(func) is not types.FunctionType or not self.names.allowed(func.__module__):
                raise ValueError(f"not a checkpoint (method {name!r} of {type(owner).__name__})")
            return types.MethodType(func, owner)
        if kind == "namedtuple":
            cls = self.names.resolve(node["class"])
            if not issubclass(cls, tuple):
                raise ValueError(f"not a checkpoint ({node['class']} is no namedtuple)")
            # tuple.__new__, not the class's: nothing but the items is involved
            return self._remember(node, tuple.__new__(cls, [self.decode(v) for v in node["items"]]))
        if kind == "object":
            cls = self.names.resolve(node["class"])
            obj = self._remember(node, cls.__new__(cls))
            state = self.decode(node["state"])
            if _custom(cls, "__setstate__"):
                obj.__setstate__(state)
            else:
                obj.__dict__.update(state)
            return obj
        raise ValueError(f"not a checkpoint (node {kind!r} in the state)")

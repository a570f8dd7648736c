"""Raw access to MuJoCo from compiled (Numba) code: ``mj_step`` by address, and ``mjData`` /
``mjContact`` fields read at their byte offsets.

A fall's contacts are recorded at every physics step. Through the Python bindings that costs
~12 us a step on top of ``mj_step``'s ~16 us, so a compiled loop calls ``mj_step`` itself
(:func:`call_step`, the C function of the library the bindings loaded) and reads the contacts
from memory (:func:`load_f64`, :func:`load_i32`, :func:`load_i64`).

The offsets come from the structs' declarations that the bindings ship (``mujoco.introspect``),
laid out with the C rules by :mod:`ctypes`, and are checked against the bindings' own views of
a live ``mjData`` before first use (:func:`layout`): a MuJoCo whose layout differs is refused
with an error, never read wrongly.
"""

from __future__ import annotations

import ctypes
import functools
import glob
import os
from dataclasses import dataclass

import mujoco
import numpy as np
from llvmlite import ir
from numba import cfunc, types
from numba.extending import intrinsic

_SCALARS = {"int": ctypes.c_int, "mjtBool": ctypes.c_ubyte, "mjtByte": ctypes.c_ubyte,
            "mjtNum": ctypes.c_double, "mjtSize": ctypes.c_int64, "size_t": ctypes.c_size_t,
            "uint64_t": ctypes.c_uint64, "uintptr_t": ctypes.c_size_t}


def _ctype(t, structs: dict):
    from mujoco.introspect import ast_nodes

    if isinstance(t, ast_nodes.PointerType):
        return ctypes.c_void_p
    if isinstance(t, ast_nodes.ArrayType):
        n = int(np.prod(t.extents))
        return _ctype(t.inner_type, structs) * n
    name = t.name
    if name in _SCALARS:
        return _SCALARS[name]
    return _struct(name, structs)


def _struct(name: str, structs: dict) -> type[ctypes.Structure]:
    from mujoco.introspect import structs as decls

    if name not in structs:
        fields = [(f.name, _ctype(f.type, structs)) for f in decls.STRUCTS[name].fields]
        structs[name] = type(name, (ctypes.Structure,), {"_fields_": fields})
    return structs[name]


@dataclass(frozen=True)
class Layout:
    """Byte offsets (``mjData`` fields, ``mjContact`` fields) and ``sizeof(mjContact)``."""

    ncon: int
    contact: int  # the mjContact* field
    efc_force: int  # the mjtNum* field
    con_size: int
    con_pos: int
    con_frame: int
    con_dim: int
    con_geom: int
    con_efc_address: int

    def as_array(self) -> np.ndarray:
        return np.array([self.ncon, self.contact, self.efc_force, self.con_size, self.con_pos,
                         self.con_frame, self.con_dim, self.con_geom, self.con_efc_address],
                        np.int64)


def _read(address: int, ctype):
    return ctype.from_address(address).value


@functools.lru_cache(maxsize=1)
def layout() -> Layout:
    """The offsets, checked on a live simulation (a sphere resting on a plane)."""
    structs: dict = {}
    data_t, con_t = _struct("mjData", structs), _struct("mjContact", structs)
    lay = Layout(data_t.ncon.offset, data_t.contact.offset, data_t.efc_force.offset,
                 ctypes.sizeof(con_t), con_t.pos.offset, con_t.frame.offset, con_t.dim.offset,
                 con_t.geom.offset, con_t.efc_address.offset)
    m = mujoco.MjModel.from_xml_string(
        '<mujoco><worldbody><geom type="plane" size="1 1 .1"/><body pos="0 0 .2">'
        '<freejoint/><geom size=".1"/></body></worldbody></mujoco>')
    d = mujoco.MjData(m)
    mujoco.mj_step(m, d, nstep=200)
    con = d.contact
    base = _read(d._address + lay.contact, ctypes.c_void_p)
    ok = (d.ncon > 0 and d.nefc > 0
          and _read(d._address + lay.ncon, ctypes.c_int) == d.ncon
          and base == con.dist.ctypes.data
          and _read(d._address + lay.efc_force, ctypes.c_void_p) == d.efc_force.ctypes.data
          and con.pos.strides[0] == lay.con_size
          and con.pos.ctypes.data == base + lay.con_pos
          and con.frame.ctypes.data == base + lay.con_frame
          and con.dim.ctypes.data == base + lay.con_dim
          and con.geom.ctypes.data == base + lay.con_geom
          and con.efc_address.ctypes.data == base + lay.con_efc_address)
    if not ok:
        raise RuntimeError(f"MuJoCo {mujoco.__version__}: the mjData / mjContact layout is not "
                           "the one its declarations give; fallgen pins mujoco==4.0.0")
    return lay


@functools.lru_cache(maxsize=1)
def mj_step_address() -> int:
    """Address of ``mj_step`` in the MuJoCo library the Python bindings loaded."""
    here = os.path.dirname(mujoco.__file__)
    names = [p for pat in ("libmujoco.so*", "libmujoco*.dylib", "mujoco.dll")
             for p in sorted(glob.glob(os.path.join(here, pat)))]
    if not names:
        raise RuntimeError(f"no MuJoCo shared library next to {mujoco.__file__}")
    lib = ctypes.CDLL(names[0])
    return ctypes.cast(lib.mj_step, ctypes.c_void_p).value


@cfunc(types.float64(), cache=True)
def _no_clock():
    return 0.0


@functools.lru_cache(maxsize=1)
def _no_clock_pointer():
    return ctypes.CFUNCTYPE(ctypes.c_double)(_no_clock.address)


def timers_off() -> None:
    """MuJoCo's profiling timers (``mjData.timer``) off in this process: with no
    ``mjcb_time`` set, MuJoCo 4 reads the system clock at the start and end of each stage of a
    step, ~20 reads a step (~0.5 us of a rehearsal step's ~4 us); with this clock, which always
    reads 0, every timer reads 0 s and counts its calls as before. Nothing in a simulation reads
    them: the same steps, to the bit (``tests/physics/test_contact_kernel.py``). Idempotent."""
    clock = _no_clock_pointer()
    if mujoco.get_mjcb_time() is not clock:
        mujoco.set_mjcb_time(clock)


# --- intrinsics (for @njit code) ----------------------------------------------------------------

_I8P = ir.IntType(8).as_pointer()


@intrinsic
def call_step(typingctx, fn, model, data):
    """``((void (*)(const mjModel*, mjData*)) fn)(model, data)``, all three as addresses."""

    def codegen(context, builder, sig, args):
        fnty = ir.FunctionType(ir.VoidType(), [_I8P, _I8P])
        f = builder.inttoptr(args[0], fnty.as_pointer())
        builder.call(f, [builder.inttoptr(args[1], _I8P), builder.inttoptr(args[2], _I8P)])
        return context.get_dummy_value()

    return types.void(types.int64, types.int64, types.int64), codegen


def _loader(llvm_type, nb_type):
    @intrinsic
    def load(typingctx, address):
        def codegen(context, builder, sig, args):
            return builder.load(builder.inttoptr(args[0], llvm_type.as_pointer()))

        return nb_type(types.int64), codegen

    return load


load_f64 = _loader(ir.DoubleType(), types.float64)
load_i32 = _loader(ir.IntType(32), types.int32)
load_i64 = _loader(ir.IntType(64), types.int64)

__all__ = ["Layout", "call_step", "layout", "load_f64", "load_i32", "load_i64",
           "mj_step_address", "timers_off"]

"""Hardware counters of this process (user-mode CPU cycles and instructions) through Linux ``perf_event_open``.

Cycles spent in this process's user code hardly depend on what else the machine runs, unlike wall time, so a
ratio of cycles stays meaningful on a busy machine. ``Counters.open()`` returns None where the kernel refuses
(no PMU in a VM, ``perf_event_paranoid`` > 2, not Linux): callers then report wall and CPU time only.
"""

from __future__ import annotations

import ctypes
import os
import platform
import struct

_SYSCALL = {"x86_64": 298, "aarch64": 241}
_HARDWARE, _CYCLES, _INSTRUCTIONS = 0, 0, 1
# perf_event_attr flag bits: disabled(0), inherit(1), exclude_kernel(5), exclude_hv(6)
_FLAGS = (1 << 1) | (1 << 5) | (1 << 6)


class _Attr(ctypes.Structure):
    _fields_ = [("type", ctypes.c_uint32), ("size", ctypes.c_uint32), ("config", ctypes.c_uint64),
                ("sample_period", ctypes.c_uint64), ("sample_type", ctypes.c_uint64),
                ("read_format", ctypes.c_uint64), ("flags", ctypes.c_uint64), ("wakeup_events", ctypes.c_uint32),
                ("bp_type", ctypes.c_uint32), ("config1", ctypes.c_uint64), ("config2", ctypes.c_uint64),
                ("branch_sample_type", ctypes.c_uint64), ("sample_regs_user", ctypes.c_uint64),
                ("sample_stack_user", ctypes.c_uint32), ("clockid", ctypes.c_int32),
                ("sample_regs_intr", ctypes.c_uint64), ("aux_watermark", ctypes.c_uint32),
                ("sample_max_stack", ctypes.c_uint16), ("reserved", ctypes.c_uint16)]


class Counters:
    """User-mode cycles and instructions of this process (its threads included) since it was opened."""

    def __init__(self, fds: list[int]) -> None:
        self._fds = fds

    @classmethod
    def open(cls) -> Counters | None:
        number = _SYSCALL.get(platform.machine())
        if number is None or os.name != "posix":
            return None
        libc = ctypes.CDLL(None, use_errno=True)
        fds: list[int] = []
        for config in (_CYCLES, _INSTRUCTIONS):
            attr = _Attr(type=_HARDWARE, size=ctypes.sizeof(_Attr), config=config, flags=_FLAGS)
            fd = libc.syscall(number, ctypes.byref(attr), 0, -1, -1, 0)
            if fd < 0:
                for f in fds:
                    os.close(f)
                return None
            fds.append(fd)
        return cls(fds)

    def read(self) -> tuple[int, int]:
        """(cycles, instructions) counted so far."""
        out = [struct.unpack("Q", os.read(fd, 8))[0] for fd in self._fds]
        return out[0], out[1]

    def close(self) -> None:
        for fd in self._fds:
            os.close(fd)
        self._fds = []

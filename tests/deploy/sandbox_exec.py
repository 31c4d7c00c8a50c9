"""Run a command under the seccomp filters systemd would load for a unit, without systemd.

    python sandbox_exec.py [--syscalls FILE] [--errno EPERM] [--families AF_UNIX,AF_NETLINK]
                           [--mdwe] [--no-realtime] -- COMMAND [ARGS...]

CI machines (and this one) have no systemd as PID 1, so `systemd-run -p ...` cannot apply a unit's
sandbox. The settings that matter most for a GL client, the system call filter and
MemoryDenyWriteExecute=, are plain seccomp filters, and systemd builds them the same way as here
(src/shared/seccomp-util.c), each as its own filter; the kernel applies the strictest answer:

--syscalls FILE   SystemCallFilter= as an allow-list: the names in FILE (one a line, groups already
                  expanded by the caller with `systemd-analyze syscall-filter`); any other system
                  call fails with --errno (SystemCallErrorNumber=), or kills with --errno kill.
                  Only the native architecture is allowed (SystemCallArchitectures=native).
--families LIST   RestrictAddressFamilies=: socket() with any other family fails with EAFNOSUPPORT.
--mdwe            MemoryDenyWriteExecute=yes: mmap with PROT_WRITE|PROT_EXEC, mprotect and
                  pkey_mprotect adding PROT_EXEC, and shmat with SHM_EXEC fail with EPERM.
--no-realtime     RestrictRealtime=yes: sched_setscheduler with any policy but SCHED_OTHER,
                  SCHED_BATCH and SCHED_IDLE fails with EPERM (systemd's
                  seccomp_restrict_realtime: every lower policy not allowed, and all above).

Loading a filter sets no_new_privs (NoNewPrivileges=yes), as systemd does. Standard library only
(ctypes and libseccomp.so.2, which systemd itself depends on), so any Python can run it.
"""

from __future__ import annotations

import argparse
import ctypes
import ctypes.util
import errno
import os
import socket
import sys

SCMP_ACT_KILL_PROCESS = 0x80000000
SCMP_ACT_ALLOW = 0x7FFF0000
SCMP_CMP_EQ, SCMP_CMP_GE, SCMP_CMP_GT, SCMP_CMP_MASKED_EQ = 4, 5, 6, 7
PROT_WRITE, PROT_EXEC = 0x2, 0x4
SHM_EXEC = 0o100000
AF_MAX = 46  # linux/socket.h in Debian 12's kernel headers
#: What RestrictRealtime=yes leaves: SCHED_OTHER, SCHED_BATCH, SCHED_IDLE (linux/sched.h).
NOT_REALTIME = (0, 3, 5)


def SCMP_ACT_ERRNO(code: int) -> int:
    return 0x00050000 | (code & 0xFFFF)


class ArgCmp(ctypes.Structure):
    _fields_ = [
        ("arg", ctypes.c_uint),
        ("op", ctypes.c_int),
        ("datum_a", ctypes.c_uint64),
        ("datum_b", ctypes.c_uint64),
    ]


class Seccomp:
    def __init__(self):
        name = ctypes.util.find_library("seccomp") or "libseccomp.so.2"
        lib = ctypes.CDLL(name, use_errno=True)
        lib.seccomp_init.restype = ctypes.c_void_p
        lib.seccomp_init.argtypes = [ctypes.c_uint32]
        lib.seccomp_syscall_resolve_name.argtypes = [ctypes.c_char_p]
        lib.seccomp_rule_add_array.argtypes = [
            ctypes.c_void_p,
            ctypes.c_uint32,
            ctypes.c_int,
            ctypes.c_uint,
            ctypes.POINTER(ArgCmp),
        ]
        lib.seccomp_load.argtypes = [ctypes.c_void_p]
        lib.seccomp_release.argtypes = [ctypes.c_void_p]
        self.lib = lib

    def number(self, name: str) -> int:
        """The native number of a system call, or -1 when this architecture has none."""
        nr = self.lib.seccomp_syscall_resolve_name(name.encode())
        return nr if nr >= 0 else -1

    def load(self, default: int, rules: list[tuple[int, str, list[tuple[int, int, int, int]]]]):
        """One filter: ``default`` action, and (action, syscall, [(arg, op, a, b)]) rules."""
        ctx = self.lib.seccomp_init(default)
        if not ctx:
            raise OSError("seccomp_init failed")
        try:
            for action, name, cmps in rules:
                nr = self.number(name)
                if nr < 0:
                    continue
                array = (ArgCmp * max(1, len(cmps)))(*[ArgCmp(*c) for c in cmps])
                rc = self.lib.seccomp_rule_add_array(ctx, action, nr, len(cmps), array)
                if rc < 0:
                    raise OSError(-rc, f"seccomp_rule_add {name}: {os.strerror(-rc)}")
            rc = self.lib.seccomp_load(ctx)
            if rc < 0:
                raise OSError(-rc, f"seccomp_load: {os.strerror(-rc)}")
        finally:
            self.lib.seccomp_release(ctx)


def main(argv: list[str]) -> int:
    parser = argparse.ArgumentParser()
    parser.add_argument("--syscalls")
    parser.add_argument("--errno", default="EPERM")
    parser.add_argument("--families")
    parser.add_argument("--mdwe", action="store_true")
    parser.add_argument("--no-realtime", action="store_true")
    parser.add_argument("command", nargs=argparse.REMAINDER)
    args = parser.parse_args(argv)
    command = args.command[1:] if args.command[:1] == ["--"] else args.command
    if not command:
        parser.error("no command")
    sc = Seccomp()
    if args.families:
        allowed = {int(getattr(socket, f)) for f in args.families.split(",")}
        rules = [
            (SCMP_ACT_ERRNO(errno.EAFNOSUPPORT), "socket", [(0, SCMP_CMP_EQ, af, 0)])
            for af in range(AF_MAX)
            if af not in allowed
        ]
        rules.append((SCMP_ACT_ERRNO(errno.EAFNOSUPPORT), "socket", [(0, SCMP_CMP_GE, AF_MAX, 0)]))
        sc.load(SCMP_ACT_ALLOW, rules)
    if args.mdwe:
        wx = PROT_WRITE | PROT_EXEC
        eperm = SCMP_ACT_ERRNO(errno.EPERM)
        sc.load(
            SCMP_ACT_ALLOW,
            [
                (eperm, "mmap", [(2, SCMP_CMP_MASKED_EQ, wx, wx)]),
                (eperm, "mprotect", [(2, SCMP_CMP_MASKED_EQ, PROT_EXEC, PROT_EXEC)]),
                (eperm, "pkey_mprotect", [(2, SCMP_CMP_MASKED_EQ, PROT_EXEC, PROT_EXEC)]),
                (eperm, "shmat", [(2, SCMP_CMP_MASKED_EQ, SHM_EXEC, SHM_EXEC)]),
            ],
        )
    if args.no_realtime:
        eperm = SCMP_ACT_ERRNO(errno.EPERM)
        top = max(NOT_REALTIME)
        rules = [
            (eperm, "sched_setscheduler", [(1, SCMP_CMP_EQ, policy, 0)])
            for policy in range(top)
            if policy not in NOT_REALTIME
        ]
        rules.append((eperm, "sched_setscheduler", [(1, SCMP_CMP_GT, top, 0)]))
        sc.load(SCMP_ACT_ALLOW, rules)
    # Last, as systemd does: the allow-list does not allow loading further filters.
    if args.syscalls:
        with open(args.syscalls, encoding="ascii") as listed:
            names = [line.strip() for line in listed if line.strip() and not line.startswith("#")]
        deny = (
            SCMP_ACT_KILL_PROCESS
            if args.errno == "kill"
            else SCMP_ACT_ERRNO(getattr(errno, args.errno))
        )
        sc.load(deny, [(SCMP_ACT_ALLOW, name, []) for name in names])
    os.execvp(command[0], command)


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))

#!/usr/bin/env python3
"""Static worst-case stack depth of a Thumb-2 firmware ELF, for an image that cannot be run
here (the board image: QEMU has none of its peripherals, so its painted stack cannot be read).

From `llvm-objdump -d`: each function's frame (push, vpush, sub sp, #imm) and its direct calls
(bl, blx to a label) and tail calls (b.w to another function); the deepest chain from each
root. Indirect calls (blx rN: the executor polling a task, defmt's logger) are not followed:
pass the task's poll function as a root and add the frames that call it. A frame that moves sp
by a register is reported as dynamic (none in this firmware).

Checked against the emulation image, whose painted stack is measured under QEMU: 14 292 B
estimated (the preflight task's 14 260 B under main's and the run loop's 32 B) against 14 460 B
painted over a run with the health step; the 168 B it misses are the SysTick exception's
frame, which can land on the deepest point (the board image enables no interrupt).

    stack_depth.py ELF ROOT [ROOT...]      ROOT: a substring of a (mangled) function name
    OBJDUMP=path/to/llvm-objdump           default: llvm-objdump on PATH
"""
import functools
import os
import re
import subprocess
import sys


def functions(elf):
    objdump = os.environ.get("OBJDUMP", "llvm-objdump")
    text = subprocess.run(
        [objdump, "-d", "--no-show-raw-insn", "-C", elf],
        capture_output=True, text=True, check=True,
    ).stdout
    funcs, cur = {}, None
    for line in text.splitlines():
        head = re.match(r"^[0-9a-f]+ <(.*)>:$", line)
        if head:
            if not head.group(1).startswith("$"):  # mapping symbols ($t, $d) continue a function
                cur = {"frame": 0, "calls": set(), "tails": set(), "dynamic": False}
                funcs[head.group(1)] = cur
                name = head.group(1)
            continue
        parts = line.split("\t")
        if cur is None or len(parts) < 2:
            continue
        op, args = parts[1].strip(), (parts[2] if len(parts) > 2 else "")
        if op.startswith("push"):
            cur["frame"] += 4 * len(re.findall(r"\b(?:r\d+|lr|ip|fp)\b", args))
        elif op.startswith("vpush"):
            d = [int(x) for x in re.findall(r"\bd(\d+)", args)]
            s = re.findall(r"\bs\d+", args)
            cur["frame"] += 8 * (d[-1] - d[0] + 1 if "-" in args and len(d) == 2 else len(d)) + 4 * len(s)
        elif op.startswith("sub") and args.startswith("sp, "):
            imm = re.search(r"#(0x[0-9a-f]+|\d+)", args)  # newer objdumps print hex
            if imm:
                cur["frame"] += int(imm.group(1), 0)
            else:
                cur["dynamic"] = True
        target = re.search(r"<([^>+]+)>", args)
        if target and op in ("bl", "blx"):
            cur["calls"].add(target.group(1))
        elif target and op in ("b", "b.w") and target.group(1) != name:
            cur["tails"].add(target.group(1))
    return funcs


def main():
    if len(sys.argv) < 3:
        print(__doc__, file=sys.stderr)
        return 2
    funcs = functions(sys.argv[1])
    sys.setrecursionlimit(100_000)

    @functools.lru_cache(maxsize=None)
    def deepest(name, seen=frozenset()):
        f = funcs.get(name)
        if f is None or name in seen:
            return 0, ()
        seen = seen | {name}
        below = max((deepest(c, seen) for c in f["calls"]), default=(0, ()))
        best = (f["frame"] + below[0], ((name, f["frame"]),) + below[1])
        for t in f["tails"]:  # the frame is popped before a tail call
            tail = deepest(t, seen)
            best = max(best, tail)
        return best

    status = 0
    for root in sys.argv[2:]:
        names = [n for n in funcs if root in n]
        if not names:
            print(f"no function matches {root!r}", file=sys.stderr)
            status = 1
        for n in names:
            depth, chain = deepest(n)
            print(f"stack {depth} {n}")
            for f, frame in chain:
                print(f"    {frame:6d} {f[:100]}")
    dynamic = [n for n, f in funcs.items() if f["dynamic"]]
    if dynamic:
        print("dynamic frames (not bounded here):", ", ".join(dynamic[:10]))
    return status


if __name__ == "__main__":
    sys.exit(main())

"""Pure-Python baseline for the `can/candump_source` bench: parse the same three-finger
`biotac-mux` candump log (2000 cycles x 3 fingertips x 9 frames) and reassemble 24-electrode
frames (mux 0-5, four 12-bit big-endian fields in bytes 1-6). Prints the median of 7 runs.

Run: python3 gradtac-io/benches/python_candump_baseline.py
"""
import statistics
import time

CYCLES = 2000


def make_log():
    lines = []
    for k in range(CYCLES):
        for f in range(3):
            for m in range(9):
                t = 1_700_000_000_000_000_000 + k * 10_000_000 + f * 1_000_000 + m * 100_000
                v = 1500 + k % 1000
                d = [m, v >> 4, ((v & 0xF) << 4) | (v >> 8), v & 0xFF, v >> 4, ((v & 0xF) << 4) | (v >> 8), v & 0xFF, 0]
                lines.append("(%d.%06d) can0 %03X#%s" % (t // 10**9, (t % 10**9) // 1000, 0x100 + f, "".join("%02X" % b for b in d)))
    return "\n".join(lines) + "\n"


def decode(text):
    out = []
    sets = {}
    for line in text.splitlines():
        stamp, iface, frame = line.split()
        secs, frac = stamp[1:-1].split(".")
        t = int(secs) * 10**9 + int(frac.ljust(9, "0"))
        ident, data = frame.split("#")
        can_id = int(ident, 16)
        b = bytes.fromhex(data)
        f = can_id - 0x100
        if not 0 <= f < 3 or len(b) != 8:
            continue
        m = b[0]
        if m >= 6:
            continue
        vals = [(b[1] << 4) | (b[2] >> 4), ((b[2] & 0xF) << 8) | b[3], (b[4] << 4) | (b[5] >> 4), ((b[5] & 0xF) << 8) | b[6]]
        s = sets.setdefault(f, [None] * 24)
        s[4 * m:4 * m + 4] = [float(x) for x in vals]
        if all(x is not None for x in s):
            out.append((f, t, s))
            sets[f] = [None] * 24
    return out


if __name__ == "__main__":
    text = make_log()
    times = []
    for _ in range(7):
        t0 = time.perf_counter()
        out = decode(text)
        times.append(time.perf_counter() - t0)
    assert len(out) == 3 * CYCLES
    n = len(text.splitlines())
    med = statistics.median(times)
    print(f"python candump parse+decode: median {med * 1e3:.1f} ms for {n} lines ({n / med / 1e6:.2f} M lines/s)")

"""Check rerun recordings (.rrd) written by `gradtac run --view-save` and `gradtac view --save`
against the Parquet outputs of the same run, with rerun's own reader (the rerun-sdk Python
package of the pinned version).

usage: view_check.py OUT_DIR RRD [RRD ...]

For every sensor found in the outputs it checks, in each recording:
  entity paths    the entities the view's docs promise for the outputs present;
  counts          rows per entity against the rows of the matching Parquet output
                  (events: the sum of the logged counts against the event rows);
  times           the logged times (the `time` duration timeline for these rate-timed
                  sources) equal the Parquet time column, nanosecond for nanosecond;
  blueprint       the recording carries a blueprint store (one panel per sensor).
Prints one line per check and 'N passed, 0 failed' at the end; exits non-zero on a failure.
"""

import collections
import glob
import os
import sys

import numpy as np
import pyarrow as pa
import pyarrow.compute as pc
import pyarrow.parquet as pq
import rerun as rr
from rerun.experimental import RrdReader

TIMELINE = "time"


def ns(col):
    """A pyarrow duration / timestamp / int64 column as int64 nanoseconds."""
    col = pa.chunked_array(col) if not isinstance(col, pa.ChunkedArray) else col
    if pa.types.is_duration(col.type) or pa.types.is_timestamp(col.type):
        col = col.cast(pa.int64())
    return np.asarray(col.to_numpy(zero_copy_only=False), dtype=np.int64)


def read_parquet(path):
    if os.path.isdir(path):
        files = sorted(glob.glob(os.path.join(path, "**", "*.parquet"), recursive=True))
        tables = []
        for f in files:
            t = pq.read_table(f)
            if "sensor" not in t.column_names:
                part = [p for p in f.split(os.sep) if p.startswith("sensor=")][-1][len("sensor="):]
                t = t.append_column("sensor", pa.array([part] * t.num_rows))
            tables.append(t.select([c for c in t.column_names]))
        return pa.concat_tables(tables, promote_options="default")
    return pq.read_table(path)


def rows_of(table, sensor, mask=None):
    t = table.filter(pc.equal(table["sensor"], sensor))
    if mask is not None:
        t = t.filter(mask(t))
    return t


class Recording:
    """Per entity: the times (ns) and record batches of its temporal rows."""

    def __init__(self, path):
        reader = RrdReader(path)
        self.blueprints = len(reader.blueprints())
        self.rows = collections.defaultdict(list)  # entity -> [(time_ns, {component: value})]
        self.timelines = set()
        for chunk in reader.stream():
            if chunk.is_static:
                continue
            rb = chunk.to_record_batch()
            names = rb.schema.names
            times = None
            for n in names:
                if n == TIMELINE:
                    times = ns(rb.column(n))
                if n in ("time", "utc"):
                    self.timelines.add(n)
            if times is None:
                continue
            comps = [n for n in names if ":" in n]
            for i in range(rb.num_rows):
                vals = {}
                for c in comps:
                    v = rb.column(c)[i]
                    if v.is_valid:
                        vals[c] = v.as_py()
                self.rows[chunk.entity_path].append((int(times[i]), vals))

    def entity(self, path, component):
        """Sorted (time, value) of the rows of `path` holding `component` (a suffix match)."""
        out = []
        for t, vals in self.rows.get(path, []):
            for k, v in vals.items():
                if k.endswith(component):
                    out.append((t, v))
        return sorted(out, key=lambda x: x[0])


def main():
    out_dir, rrds = sys.argv[1], sys.argv[2:]
    outputs = {}
    for name, path in [
        ("source", "raw"),
        ("normalise", "normalised.parquet"),
        ("events", "events.parquet"),
        ("surface", "surfaces.parquet"),
        ("contour", "contours.parquet"),
        ("track", "tracks.parquet"),
        ("servo", "servo.parquet"),
        ("slip", "slip.parquet"),
    ]:
        p = os.path.join(out_dir, path)
        if os.path.exists(p):
            outputs[name] = read_parquet(p)
    sensors = sorted(set(outputs["source"]["sensor"].to_pylist()))
    passed, failed = 0, 0

    def check(ok, what):
        nonlocal passed, failed
        print(("ok   " if ok else "FAIL ") + what)
        if ok:
            passed += 1
        else:
            failed += 1

    strips = collections.Counter()
    for rrd in rrds:
        rec = Recording(rrd)
        tag = os.path.basename(rrd)
        check(rec.blueprints >= 1, f"{tag}: carries a blueprint ({rec.blueprints} stores)")
        check(rec.timelines == {TIMELINE}, f"{tag}: timelines {sorted(rec.timelines)} == ['{TIMELINE}'] (rate-timed sources)")
        print(f"{tag}: entities {sorted(rec.rows)}")
        for s in sensors:

            def same(entity, component, table, time_col, mask=None, label=None):
                got = rec.entity(f"/{s}/{entity}", component)
                want = rows_of(table, s, mask)
                want_t = np.sort(ns(want[time_col]))
                got_t = np.array([t for t, _ in got], dtype=np.int64)
                check(len(got) == want.num_rows,
                      f"{tag}: /{s}/{entity} {component}: {len(got)} rows == {want.num_rows} {label or ''} Parquet rows")
                check(len(got_t) == len(want_t) and bool(np.all(got_t == want_t)),
                      f"{tag}: /{s}/{entity} times equal the Parquet `{time_col}` column (ns)")
                return got, want

            got, want = same("series/raw", "scalars", outputs["source"], "time", label="source")
            if got:
                v = np.array([g[1] for g in got], dtype=float)
                w = np.stack(want.sort_by("time")["values"].to_numpy(zero_copy_only=False))
                check(v.shape == w.shape and np.array_equal(v, w), f"{tag}: /{s}/series/raw values equal the source's")
            got = rec.entity(f"/{s}/plane/raw", "colors")
            check(len(got) == rows_of(outputs["source"], s).num_rows, f"{tag}: /{s}/plane/raw colours per frame: {len(got)}")
            if "normalise" in outputs:
                same("series/normalised", "scalars", outputs["normalise"], "time", label="normalise")
            if "events" in outputs:
                got = rec.entity(f"/{s}/series/events", "scalars")
                total = int(sum(sum(v) for _, v in got))
                want = rows_of(outputs["events"], s).num_rows
                check(total == want, f"{tag}: /{s}/series/events: {total} events logged == {want} event rows")
                frames = len(set(ns(rows_of(outputs['events'], s)['frame_time']).tolist()))
                check(len(got) == frames, f"{tag}: /{s}/series/events: {len(got)} rows == {frames} frames with events")
            if "surface" in outputs:
                same("plane/surface", "buffer", outputs["surface"], "end", label="surface")
            if "contour" in outputs:
                same("series/contact_area", "scalars", outputs["contour"], "end",
                     mask=lambda t: pc.and_(pc.equal(t["contact"], True), pc.is_valid(t["area_mm2"])),
                     label="contact=true contour")
                # outlines: the contours that have one (the centroid locator's have none)
                got, _ = same("plane/contour", "strips", outputs["contour"], "end",
                              mask=lambda t: pc.greater(pc.fill_null(pc.list_value_length(t["polygon"]), 0), 0),
                              label="with-polygon contour")
                strips[tag] += len(got)
            if "track" in outputs:
                same("plane/contact", "positions", outputs["track"], "time",
                     mask=lambda t: pc.equal(t["state"], "contact"), label="state=contact track")
            if "servo" in outputs:
                same("series/servo", "scalars", outputs["servo"], "time",
                     mask=lambda t: pc.equal(t["action"], "move"), label="action=move servo")
        if "slip" in outputs:
            got = rec.entity("/slip/log", "text")
            want = outputs["slip"]
            check(len(got) == want.num_rows, f"{tag}: /slip/log: {len(got)} rows == {want.num_rows} slip events")
            got_t = np.array([t for t, _ in got], dtype=np.int64)
            check(bool(np.all(got_t == np.sort(ns(want["time"])))), f"{tag}: /slip/log times equal the slip `time` column")
            classes = [v[0].split("→ ")[1].split(" ")[0] for _, v in got]
            check(classes == want.sort_by("time")["class"].to_pylist(), f"{tag}: /slip/log classes equal the slip `class` column")
    if "contour" in outputs:
        for tag, k in sorted(strips.items()):
            check(k > 0, f"{tag}: {k} contour outlines drawn (the scene's contours have polygons)")
    print(f"{passed} passed, {failed} failed")
    sys.exit(1 if failed else 0)


if __name__ == "__main__":
    main()

"""Read a recording back (tests and scripts): entity paths, series on a timeline, static values.

Built on ``rerun.chunk.RrdReader`` and pyarrow only. Every cell Rerun stores is a batch (a list),
so a scalar reads as ``[x]`` and a translation as ``[[x, y, z]]``.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pyarrow as pa
from rerun.chunk import RrdReader


class Recording:
    """The chunks of a recording file, with small queries over them."""

    def __init__(self, path: str | Path) -> None:
        self.path = Path(path)
        self.chunks = RrdReader(str(self.path)).stream().to_chunks()

    def entity_paths(self) -> set[str]:
        return {c.entity_path for c in self.chunks if not c.entity_path.startswith("/__")}

    def timelines(self) -> set[str]:
        return {name for c in self.chunks for name in c.timeline_names}

    def series(self, entity: str, component: str, timeline: str) -> pa.Table:
        """``[timeline, component]`` of one entity's temporal data, sorted by time."""
        entity = "/" + entity.lstrip("/")
        parts = []
        for chunk in self.chunks:
            if chunk.entity_path != entity or chunk.is_static:
                continue
            batch = chunk.to_record_batch()
            if component in batch.schema.names and timeline in batch.schema.names:
                parts.append(pa.table({timeline: batch.column(timeline), component: batch.column(component)}))
        if not parts:
            raise KeyError(f"{self.path}: no {component} of {entity} on timeline {timeline!r}")
        return pa.concat_tables(parts).sort_by(timeline)

    def static(self, entity: str, component: str) -> Any:
        """The static value of one entity's component (None if there is none)."""
        entity = "/" + entity.lstrip("/")
        for chunk in self.chunks:
            if chunk.entity_path == entity and chunk.is_static:
                batch = chunk.to_record_batch()
                if component in batch.schema.names:
                    return batch.column(component)[-1].as_py()
        return None

    def latest_at(self, entity: str, component: str, timeline: str, time: Any) -> Any:
        """The value in effect at ``time`` on ``timeline`` (static data wins, as in the viewer)."""
        value = self.static(entity, component)
        if value is not None:
            return value
        table = self.series(entity, component, timeline)
        times = table.column(timeline).to_numpy()
        index = int(np.searchsorted(times, time, side="right")) - 1
        return None if index < 0 else table.column(component)[index].as_py()

#!/usr/bin/env python3
"""A Rerun blueprint for rover-power logs: the decoded sample batches, the board's model frames and
its health counters as tables on the run-time timeline.

    python3 rerun/blueprint.py [OUT.rbl]        (default: rover-power.rbl)
    rerun mcap convert run-1.mcap --application-id rover_power -o run-1.rrd
    rerun run-1.rrd rover-power.rbl

A blueprint applies to recordings of its application id, `rover_power` (hence the convert
option). Each table shows one channel's decoded protobuf column, which Rerun names after the
channel's schema (`rover_power.SampleBatch:message` on `/rover_power/sample_batch`). The samples
come about 20 to a message, so a row of the sample table is a batch: arrays of `t_s` and, per
side, `power_w`, `bus_raw`, `current_raw`, `cmd_mps`. Needs the `rerun-sdk` package
(pip install rerun-sdk; checked with 0.41).
"""
import sys

import rerun.blueprint as rrb

APPLICATION_ID = "rover_power"
RUN_TIME = "message_publish_time"  # publish_time is run time; message_log_time the wall clock


def blueprint() -> rrb.Blueprint:
    def table(topic, message, name):
        # The decoded message's column alone (the channel and schema columns are static); Rerun
        # names it after the channel's schema, `message`.
        column = rrb.components.ComponentColumnSelector(entity_path=topic,
                                                        component=f"{message}:message")
        query = rrb.archetypes.DataframeQuery(timeline=RUN_TIME, select=[RUN_TIME, column])
        return rrb.DataframeView(origin=topic, name=name, query=query)

    return rrb.Blueprint(
        rrb.Vertical(
            table("/rover_power/sample_batch", "rover_power.SampleBatch",
                  "Sample batches (about 20 a row): power, registers, command per side"),
            rrb.Horizontal(
                table("/rover_power/model", "rover_power.Model",
                      "The board's model: power, energy, tau per side"),
                table("/rover_power/status", "rover_power.Status", "Board health"),
            ),
            row_shares=[3, 2],
        ),
        rrb.TimePanel(timeline=RUN_TIME),
        collapse_panels=False,
    )


def main() -> int:
    out = sys.argv[1] if len(sys.argv) > 1 else "rover-power.rbl"
    blueprint().save(APPLICATION_ID, out)
    print(out)
    return 0


if __name__ == "__main__":
    sys.exit(main())

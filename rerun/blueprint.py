#!/usr/bin/env python3
"""A Rerun blueprint for rover-power logs: the decoded samples and the board's model frames as
tables on the run-time timeline.

    python3 rerun/blueprint.py [OUT.rbl]        (default: rover-power.rbl)
    rerun mcap convert run-1.mcap --application-id rover_power -o run-1.rrd
    rerun run-1.rrd rover-power.rbl

A blueprint applies to recordings of its application id, `rover_power` (hence the convert
option). Needs the `rerun-sdk` package (pip install rerun-sdk).
"""
import sys

import rerun.blueprint as rrb

APPLICATION_ID = "rover_power"
RUN_TIME = "message_publish_time"  # publish_time is run time; message_log_time the wall clock


def blueprint() -> rrb.Blueprint:
    def table(topic, name):
        # The decoded message's column alone (the channel and schema columns are static).
        message = "rover_power." + topic.rsplit("/", 1)[1].capitalize()
        column = rrb.components.ComponentColumnSelector(entity_path=topic,
                                                        component=f"{message}:message")
        query = rrb.archetypes.DataframeQuery(timeline=RUN_TIME, select=[RUN_TIME, column])
        return rrb.DataframeView(origin=topic, name=name, query=query)

    return rrb.Blueprint(
        rrb.Vertical(
            table("/rover_power/sample", "Samples: bus, current, power, command per side"),
            rrb.Horizontal(
                table("/rover_power/model", "The board's model: power, energy, tau per side"),
                table("/rover_power/status", "Board health"),
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

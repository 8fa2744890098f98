#!/usr/bin/env python3
"""Reads a handgate recording with the independent Python readers (`mcap`, `mcap-ros2-support`)
and prints one JSON line describing it (tests/tests/recording.rs compares it with what was sent).

    read_recording.py FILE.mcap            # indexed read: header, summary, chunk/message indexes
    read_recording.py FILE.mcap --stream   # streaming read up to the first damaged record
"""
import json
import sys

from mcap.reader import make_reader
from mcap.records import Channel, Message, Schema
from mcap.stream_reader import StreamReader
from mcap_ros2.decoder import DecoderFactory

path = sys.argv[1]
stream = "--stream" in sys.argv[2:]
out = {"topics": {}, "cmd_q5": {}, "state_q5": {}, "decoded": 0}


def take(channel, decoded):
    out["decoded"] += 1
    out["topics"][channel.topic] = out["topics"].get(channel.topic, 0) + 1
    if hasattr(decoded, "motor_cmd") and len(decoded.motor_cmd) > 5:
        out["cmd_q5"].setdefault(channel.topic, []).append(decoded.motor_cmd[5].q)
    if hasattr(decoded, "motor_state") and len(decoded.motor_state) > 5:
        out["state_q5"].setdefault(channel.topic, []).append(decoded.motor_state[5].q)


with open(path, "rb") as f:
    if stream:
        # Record by record, as a reader of a file still being written (or cut short) must.
        factory, schemas, channels, decoders = DecoderFactory(), {}, {}, {}
        try:
            for record in StreamReader(f).records:
                if isinstance(record, Schema):
                    schemas[record.id] = record
                elif isinstance(record, Channel):
                    channels[record.id] = record
                elif isinstance(record, Message):
                    channel = channels[record.channel_id]
                    if channel.id not in decoders:
                        decoders[channel.id] = factory.decoder_for(channel.message_encoding, schemas[channel.schema_id])
                    take(channel, decoders[channel.id](record.data))
        except Exception as e:  # the end of a file cut short by SIGKILL
            out["error"] = f"{type(e).__name__}: {e}"
    else:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        out["profile"] = reader.get_header().profile
        summary = reader.get_summary()
        out["schema_encodings"] = sorted({s.encoding for s in summary.schemas.values()})
        out["schemas"] = sorted({s.name for s in summary.schemas.values()})
        out["message_encodings"] = sorted({c.message_encoding for c in summary.channels.values()})
        out["qos_on_every_channel"] = all("offered_qos_profiles" in c.metadata for c in summary.channels.values())
        out["chunks"] = len(summary.chunk_indexes)
        out["chunks_with_message_indexes"] = sum(1 for c in summary.chunk_indexes if c.message_index_offsets)
        out["statistics_messages"] = summary.statistics.message_count
        out["metadata"] = {m.name: dict(m.metadata) for m in reader.iter_metadata()}
        for _schema, channel, _msg, decoded in reader.iter_decoded_messages(log_time_order=False):
            take(channel, decoded)
print(json.dumps(out))

"""Decodes every decoded channel of a `launch --record` file with its schema.

Used by tests/tests/foxglove_recording.rs. Opens the file with the Python
`mcap` reader's `make_reader` (summary and footer required), then for every
message: protobuf channels are parsed with the message class of
`foxglove-schemas-protobuf` named by the schema (and the schema's
FileDescriptorSet must name the same type); JSON channels are parsed and
validated against the channel's JSON schema (`jsonschema`, the schema's own
draft); postcard channels (raw bus bytes) are counted, not decoded.
Prints one JSON report on stdout.
"""

import importlib
import json
import sys

import jsonschema
from google.protobuf import descriptor_pb2
from mcap.reader import make_reader


def proto_class(name):
    # "foxglove.SceneUpdate" -> foxglove_schemas_protobuf.SceneUpdate_pb2.SceneUpdate
    short = name.split(".", 1)[1]
    module = importlib.import_module(f"foxglove_schemas_protobuf.{short}_pb2")
    return getattr(module, short)


def main(path):
    report = {"channels": {}, "postcard": 0, "metadata": {}, "scene_ids": [], "logs": [],
              "max_log_time": 0, "min_log_time": None}
    validators = {}
    with open(path, "rb") as f:
        reader = make_reader(f)
        for record in reader.iter_metadata():
            report["metadata"][record.name] = dict(record.metadata)
        for schema, channel, message in reader.iter_messages():
            t = message.log_time
            report["max_log_time"] = max(report["max_log_time"], t)
            if report["min_log_time"] is None or t < report["min_log_time"]:
                report["min_log_time"] = t
            if channel.message_encoding == "postcard":
                report["postcard"] += 1
                continue
            entry = report["channels"].setdefault(
                channel.topic,
                {"schema": schema.name if schema else "", "encoding": channel.message_encoding,
                 "schema_encoding": schema.encoding if schema else "", "messages": 0})
            if channel.message_encoding == "protobuf":
                assert schema.encoding == "protobuf", (channel.topic, schema.encoding)
                fds = descriptor_pb2.FileDescriptorSet.FromString(schema.data)
                names = {f"{fd.package}.{m.name}" for fd in fds.file for m in fd.message_type}
                assert schema.name in names, (schema.name, sorted(names))
                cls = proto_class(schema.name)
                decoded = cls.FromString(message.data)
                if schema.name == "foxglove.SceneUpdate":
                    for entity in decoded.entities:
                        if entity.id not in report["scene_ids"]:
                            report["scene_ids"].append(entity.id)
                elif schema.name == "foxglove.Log":
                    report["logs"].append(decoded.message)
            elif channel.message_encoding == "json":
                value = json.loads(message.data)
                if schema is not None and schema.encoding == "jsonschema" and schema.data:
                    if schema.id not in validators:
                        s = json.loads(schema.data)
                        cls = jsonschema.validators.validator_for(s)
                        cls.check_schema(s)
                        validators[schema.id] = cls(s)
                    validators[schema.id].validate(value)
                    entry["validated"] = entry.get("validated", 0) + 1
            else:
                raise AssertionError(f"unexpected encoding {channel.message_encoding} on {channel.topic}")
            entry["messages"] += 1
    print(json.dumps(report))


if __name__ == "__main__":
    main(sys.argv[1])

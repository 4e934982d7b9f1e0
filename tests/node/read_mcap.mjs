// Independent MCAP reader for the pndiss tests: opens each file with @mcap/core's indexed
// reader (summary + chunk indexes), reads every message with CRC validation on, and prints
// per-topic counts, schema names, metadata and decode problems as one JSON object per file.
import { open } from "node:fs/promises";
import { McapIndexedReader } from "@mcap/core";
import { FileHandleReadable } from "@mcap/nodejs";
import { loadDecompressHandlers } from "@mcap/support";

const decompressHandlers = await loadDecompressHandlers();
const out = {};
for (const path of process.argv.slice(2)) {
  const handle = await open(path, "r");
  try {
    const reader = await McapIndexedReader.Initialize({
      readable: new FileHandleReadable(handle),
      decompressHandlers,
    });
    const res = { topics: {}, schemas: {}, metadata: {}, badJson: 0, messages: 0, library: reader.header.library };
    for (const ch of reader.channelsById.values()) {
      res.topics[ch.topic] = 0;
      res.schemas[ch.topic] = reader.schemasById.get(ch.schemaId)?.name ?? null;
    }
    const dec = new TextDecoder();
    for await (const m of reader.readMessages({ validateCrcs: true })) {
      const ch = reader.channelsById.get(m.channelId);
      res.topics[ch.topic] += 1;
      res.messages += 1;
      try { JSON.parse(dec.decode(m.data)); } catch { res.badJson += 1; }
    }
    for await (const md of reader.readMetadata()) {
      res.metadata[md.name] = Object.fromEntries(md.metadata);
    }
    out[path] = res;
  } catch (e) {
    out[path] = { error: String(e && e.message || e) };
  } finally {
    await handle.close();
  }
}
process.stdout.write(JSON.stringify(out));

// streamseg listener: print a streamseg daemon's cuts, relabels and closes (protocol v1).
//
//   node clients/js/listener.js tcp://127.0.0.1:5561 [STREAM] [--control tcp://127.0.0.1:5562]
//        [--max N] [--keys DIR]
//
// Subscribes to "cut/", "withdraw/", "segments/" and "closed/" (+ "STREAM/": topics are
// "<type>/<stream>/", filtered by prefix) and prints the lines of clients/python/listener.py.
// With --control it first makes sure the subscription is live (the `hello` handshake of
// docs/protocol.md), so nothing published after its first line, "listening on ...", is
// missed; and it follows every event of the stream (each type; other types get a line
// "STREAM: TYPE event N"), so the event numbers (`seq`, per stream) show a loss: the missing
// events are fetched from the daemon's event log (control op `since`), printed in their place
// and reported on stderr, as `streamseg listen --control` does; the `stats` heartbeats'
// `last_seq` show a loss at a stream's end. With a STREAM it stops at that stream's `closed`;
// else after --max N events. --keys DIR: CURVE with the keys `streamseg keys DIR` wrote.
// Needs the npm packages zeromq and @msgpack/msgpack (`npm ci --prefix clients/js`).
"use strict"

const crypto = require("crypto")
const zmq = require("zeromq")
const { encode, decode } = require("@msgpack/msgpack")
const { curveOptions } = require("./keys")

function option(args, name) {
  const i = args.indexOf(name)
  if (i < 0) return undefined
  const value = args[i + 1]
  args.splice(i, 2)
  return value
}

// The `hello` handshake; returns the control socket, kept for `since` requests.
async function handshake(sub, control, curve) {
  const token = crypto.randomBytes(8).toString("hex")
  const topic = `hello/${token}/`
  sub.subscribe(topic)
  const req = new zmq.Request({ linger: 0, receiveTimeout: 10000, ...curve })
  req.connect(control)
  sub.receiveTimeout = 50
  for (;;) {
    await req.send(encode({ v: 1, op: "hello", token }))
    await req.receive()
    try {
      for (;;) {
        const [got] = await sub.receive()
        if (got.toString() === topic) {
          // (a real client would keep the other events received here)
          sub.unsubscribe(topic)
          sub.receiveTimeout = -1
          return req
        }
      }
    } catch (err) {
      if (err.code !== "EAGAIN") throw err // no message within 50 ms: ask again
    }
  }
}

function line(ev) {
  switch (ev.type) {
    case "cut":
      return `${ev.stream}: cut at frame ${ev.frame} (decided at ${ev.emitted_at}` +
        `${ev.pending ? ", pending" : ""})`
    case "withdraw":
      return `${ev.stream}: withdraw of the cut at frame ${ev.frame} (at ${ev.emitted_at})`
    case "segments": {
      const runs = ev.segments.map(([a, b, label]) => `${a}-${b}:${label}`).join(", ")
      return `${ev.stream}: relabel ${ev.revision} of ${ev.start}-${ev.end}: ${runs}`
    }
    case "closed":
      return `${ev.stream}: closed (${ev.reason})`
    case "stats":
    case "hello":
      return null
    default: // confirm, rep, gap, error: followed for their numbers
      return `${ev.stream ?? "*"}: ${ev.type} event ${ev.seq}`
  }
}

// The events of `stream` numbered after `after` and below `upto` (undefined: all), from the
// event log (control op `since`, page by page); throws with the daemon's error.
async function since(req, stream, after, upto) {
  const out = []
  for (;;) {
    await req.send(encode({ v: 1, op: "since", stream, seq: after }))
    const [body] = await req.receive()
    const reply = decode(body)
    if (!reply.ok) throw new Error(reply.error)
    for (const ev of reply.events) {
      if (upto !== undefined && ev.seq >= upto) return out
      out.push(ev)
      after = ev.seq
    }
    if (!reply.more) return out
  }
}

// Events `first`..`end - 1` of `id` were missed: fetched (with a control socket, and not
// daemon-wide ones: those the subscription may not all hold) and said on stderr.
async function onHole(req, id, first, end) {
  const where = `events ${first}..${end - 1} of stream ${id}`
  if (!req || id === "*") {
    console.error(`hole: ${where} were missed (${end - first})` +
      (req ? "" : "; give --control to fetch them"))
    return []
  }
  try {
    const evs = await since(req, id, first - 1, end)
    console.error(`hole: ${where}: ${evs.length} fetched from the event log`)
    return evs
  } catch (err) {
    console.error(`hole: ${where} were missed; cannot fetch them: ${err.message}`)
    return []
  }
}

async function main(argv) {
  const args = [...argv]
  const limit = option(args, "--max")
  const control = option(args, "--control")
  const keys = option(args, "--keys")
  if (args.length < 1 || args.length > 2 || args[0].startsWith("-")) {
    console.error("usage: node listener.js ENDPOINT [STREAM] [--control ENDPOINT] [--max N] " +
      "[--keys DIR]")
    return 2
  }
  const [endpoint, stream = ""] = args
  const curve = keys ? curveOptions(keys) : {}
  const sub = new zmq.Subscriber(curve)
  sub.connect(endpoint)
  // with --control every type of the stream (its numbers must show a loss) and the
  // heartbeats (a loss at its end); without, the four this listener prints
  const suffix = stream ? `${stream}/` : ""
  const kinds = ["cut", "withdraw", "segments", "closed"]
  if (control && !stream) sub.subscribe()
  else {
    for (const kind of control ? [...kinds, "confirm", "rep", "gap", "error"] : kinds) {
      sub.subscribe(`${kind}/${suffix}`)
    }
    if (control) sub.subscribe("stats/")
  }
  const req = control ? await handshake(sub, control, curve) : null
  process.stdout.write(`listening on ${endpoint}\n`)
  const last = new Map() // stream id ("*": daemon-wide) -> last event number printed
  let seen = 0
  let done = false
  const show = (ev) => {
    const text = line(ev)
    if (text === null) return
    process.stdout.write(text + "\n")
    seen += 1
    if (ev.type === "closed" && stream && ev.stream === stream) done = true
  }
  while (!done && (limit === undefined || seen < Number(limit))) {
    const [, body] = await sub.receive()
    const ev = decode(body)
    if (ev.v !== 1) {
      console.error(`skipping protocol version ${ev.v}`)
      continue
    }
    if (req && ev.type === "stats") { // the heartbeat's numbers: a loss at a stream's tail
      for (const [id, newest] of Object.entries(ev.last_seq || {})) {
        const prev = last.get(id)
        if (prev !== undefined && newest > prev && (!stream || id === stream)) {
          for (const e of await onHole(req, id, prev + 1, newest + 1)) if (!done) show(e)
          last.set(id, newest)
        }
      }
      continue
    }
    if (ev.seq !== undefined) {
      const id = ev.stream ?? "*"
      const prev = last.get(id)
      if (prev !== undefined && ev.seq <= prev) continue // printed already, from the log
      if (prev !== undefined && ev.seq > prev + 1) {
        for (const e of await onHole(req, id, prev + 1, ev.seq)) if (!done) show(e)
      }
      last.set(id, ev.seq)
      if (done) break
    }
    show(ev)
  }
  if (req) req.close()
  sub.close()
  return 0
}

main(process.argv.slice(2)).then((code) => { process.exitCode = code })

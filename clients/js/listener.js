// streamseg listener: print a streamseg daemon's cuts, relabels and closes (protocol v1).
//
//   node clients/js/listener.js tcp://127.0.0.1:5561 [STREAM] [--control tcp://127.0.0.1:5562]
//        [--max N]
//
// Subscribes to "cut/", "withdraw/", "segments/" and "closed/" (+ "STREAM/": topics are
// "<type>/<stream>/", filtered by prefix) and prints the lines of clients/python/listener.py.
// With --control it first makes sure the subscription is live (the `hello` handshake of
// docs/protocol.md), so nothing published after its first line, "listening on ...", is
// missed. With a STREAM it stops at that stream's `closed`; else after --max N events.
// Needs the npm packages zeromq and @msgpack/msgpack (`npm ci --prefix clients/js`).
"use strict"

const crypto = require("crypto")
const zmq = require("zeromq")
const { encode, decode } = require("@msgpack/msgpack")

function option(args, name) {
  const i = args.indexOf(name)
  if (i < 0) return undefined
  const value = args[i + 1]
  args.splice(i, 2)
  return value
}

async function handshake(sub, control) {
  const token = crypto.randomBytes(8).toString("hex")
  const topic = `hello/${token}/`
  sub.subscribe(topic)
  const req = new zmq.Request({ linger: 0 })
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
          req.close()
          sub.unsubscribe(topic)
          sub.receiveTimeout = -1
          return
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
    default:
      return null
  }
}

async function main(argv) {
  const args = [...argv]
  const limit = option(args, "--max")
  const control = option(args, "--control")
  if (args.length < 1 || args.length > 2 || args[0].startsWith("-")) {
    console.error("usage: node listener.js ENDPOINT [STREAM] [--control ENDPOINT] [--max N]")
    return 2
  }
  const [endpoint, stream = ""] = args
  const sub = new zmq.Subscriber()
  sub.connect(endpoint)
  const suffix = stream ? `${stream}/` : ""
  for (const kind of ["cut", "withdraw", "segments", "closed"]) sub.subscribe(`${kind}/${suffix}`)
  if (control) await handshake(sub, control)
  process.stdout.write(`listening on ${endpoint}\n`)
  let seen = 0
  while (limit === undefined || seen < Number(limit)) {
    const [, body] = await sub.receive()
    const ev = decode(body)
    if (ev.v !== 1) {
      console.error(`skipping protocol version ${ev.v}`)
      continue
    }
    seen += 1
    const text = line(ev)
    if (text !== null) process.stdout.write(text + "\n")
    if (ev.type === "closed" && stream) break
  }
  sub.close()
  return 0
}

main(process.argv.slice(2)).then((code) => { process.exitCode = code })

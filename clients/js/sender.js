// streamseg sender: stream a joint-positions CSV to a streamseg daemon (protocol v1).
//
//   node clients/js/sender.js TAKE.csv [--to tcp://127.0.0.1:5560] [--stream ID] [--fps HZ]
//        [--batch N] [--speed X] [--units mm] [--up y] [--keys DIR]
//
// The CSV is the one `streamseg segment` reads: a header naming each coordinate
// <joint>_x, <joint>_y, <joint>_z and optionally a `time` column in seconds whose median step
// gives the frame rate when --fps does not; an empty cell or `nan` is a dropout, sent as NaN.
// One `announce` (joint names, parents all -1: the daemon's features need only the names),
// `frames` packets of --batch frames (float64 little-endian, shape (n, n_joints, 3), `seq` =
// index of the first frame), one `end`. --speed 1 (default) paces the packets in real time,
// 0 sends as fast as the daemon takes them. The same program as clients/python/sender.py.
// --keys DIR: CURVE with the keys `streamseg keys DIR` wrote (keys.js).
"use strict"

const fs = require("fs")
const path = require("path")
const zmq = require("zeromq")
const { encode } = require("@msgpack/msgpack")
const { curveOptions } = require("./keys")

const TIME = { time: 1, timestamp: 1, t: 1, time_s: 1, time_ms: 1e-3, timestamp_ms: 1e-3 }

function option(args, name, fallback) {
  const i = args.indexOf(name)
  if (i < 0) return fallback
  const value = args[i + 1]
  args.splice(i, 2)
  return value
}

function fail(message) {
  console.error(message)
  process.exit(2)
}

function readCsv(file) {
  const lines = fs.readFileSync(file, "utf8").split(/\r?\n/).filter((l) => l.trim())
  if (!lines.length) fail(`${file}: empty file, expected a header`)
  const header = lines[0].split(",").map((h) => h.trim().replace(/^"|"$/g, ""))
  const joints = []
  const columns = {}
  let timeCol = -1
  let scale = 1
  header.forEach((name, i) => {
    const low = name.toLowerCase()
    if (timeCol < 0 && low in TIME) {
      timeCol = i
      scale = TIME[low]
    } else if (name.length > 2 && "_.- :".includes(name[name.length - 2]) &&
               "xyz".includes(low[low.length - 1])) {
      const joint = name.slice(0, -2)
      if (!(joint in columns)) {
        joints.push(joint)
        columns[joint] = {}
      }
      columns[joint][low[low.length - 1]] = i
    }
  })
  if (!joints.length) fail(`${file}: no column is named <joint>_x / _y / _z`)
  const order = []
  for (const j of joints) {
    for (const a of "xyz") {
      if (!(a in columns[j])) fail(`${file}: joint ${j} needs an _x, an _y and a _z column`)
      order.push(columns[j][a])
    }
  }
  const rows = []
  const times = []
  for (const text of lines.slice(1)) {
    const cells = text.split(",")
    rows.push(order.map((c) => (cells[c] === undefined || !cells[c].trim() ? NaN : Number(cells[c]))))
    if (timeCol >= 0) times.push(Number(cells[timeCol]) * scale)
  }
  // the median positive step, rounded as streamseg's reader rounds it
  const steps = []
  for (let i = 1; i < times.length; i++) if (times[i] > times[i - 1]) steps.push(times[i] - times[i - 1])
  steps.sort((a, b) => a - b)
  let fps = null
  if (steps.length) {
    const m = steps.length >> 1
    const median = steps.length % 2 ? steps[m] : (steps[m - 1] + steps[m]) / 2
    fps = Math.round(1e6 / median) / 1e6
  }
  return { joints, rows, fps }
}

function message(type, stream, fields) {
  return [`${type}/${stream}/`, encode({ v: 1, type, stream, ...fields })]
}

const sleep = (ms) => new Promise((resolve) => setTimeout(resolve, ms))

async function main(argv) {
  const args = [...argv]
  const to = option(args, "--to", "tcp://127.0.0.1:5560")
  let stream = option(args, "--stream")
  const fpsArg = option(args, "--fps")
  const batch = Number(option(args, "--batch", "12"))
  const speed = Number(option(args, "--speed", "1"))
  const units = option(args, "--units", "mm")
  const up = option(args, "--up", "y")
  const keys = option(args, "--keys")
  if (args.length !== 1 || args[0].startsWith("-") || !(batch >= 1) || !(speed >= 0)) {
    console.error("usage: node sender.js TAKE.csv [--to ENDPOINT] [--stream ID] [--fps HZ] " +
                  "[--batch N] [--speed X] [--units mm] [--up y] [--keys DIR]")
    return 2
  }
  const file = args[0]
  const { joints, rows, fps: fromTime } = readCsv(file)
  const fps = fpsArg !== undefined ? Number(fpsArg) : fromTime
  if (!(fps > 0)) fail(`${file}: no time column gives the frame rate: give --fps HZ`)
  stream = stream || path.basename(file).replace(/\.[^.]*$/, "")
  const push = new zmq.Push({ linger: 10000, ...(keys ? curveOptions(keys) : {}) }) // what is queued at the end still goes out
  push.connect(to)
  await push.send(message("announce", stream, {
    fps, joints, parents: joints.map(() => -1), units, up,
  }))
  const width = joints.length * 3
  const t0 = Date.now() / 1000
  for (let seq = 0; seq < rows.length; seq += batch) {
    const chunk = rows.slice(seq, seq + batch)
    if (speed > 0) { // packet k leaves when its last frame is due
      const due = t0 + (seq + chunk.length) / fps / speed
      const wait = due * 1000 - Date.now()
      if (wait > 0) await sleep(wait)
    }
    const data = Buffer.alloc(chunk.length * width * 8)
    chunk.forEach((row, i) => row.forEach((v, k) => data.writeDoubleLE(v, 8 * (i * width + k))))
    await push.send(message("frames", stream, {
      seq,
      timestamp: t0 + seq / fps,
      positions: { dtype: "<f8", shape: [chunk.length, joints.length, 3], data: new Uint8Array(data) },
    }))
  }
  await push.send(message("end", stream, {}))
  push.close()
  process.stdout.write(`${stream}: sent ${rows.length} frames of ${joints.length} joints at ${fps} Hz\n`)
  return 0
}

main(process.argv.slice(2)).then((code) => { process.exitCode = code })

// CURVE for the JavaScript clients: the Z85 keys of the files `streamseg keys DIR` writes.
//
// DIR/client.key_secret holds this client's pair (`public-key = "..."`, `secret-key =
// "..."`), DIR/server.key the daemon's public key: ZeroMQ's certificate files, whose key
// lines are all a client reads. Every socket of a client to a CURVE daemon needs them, set
// before it connects (the client's public key must be in the daemon's authorized/ folder).
"use strict"

const fs = require("fs")
const path = require("path")

function keyOf(file, name) {
  let text
  try {
    text = fs.readFileSync(file, "utf8")
  } catch (err) {
    throw new Error(`cannot read ${file} (${err.code}): make the keys with \`streamseg keys DIR\``)
  }
  const m = text.match(new RegExp(`^\\s*${name}\\s*=\\s*"(.{40})"`, "m"))
  if (!m) throw new Error(`${file} has no ${name}: make the keys with \`streamseg keys DIR\``)
  return m[1]
}

// The socket options of CURVE from the keys in `dir`; exits 2 with one line when unreadable.
function curveOptions(dir) {
  try {
    const pair = path.join(dir, "client.key_secret")
    return {
      curveServerKey: keyOf(path.join(dir, "server.key"), "public-key"),
      curvePublicKey: keyOf(pair, "public-key"),
      curveSecretKey: keyOf(pair, "secret-key"),
    }
  } catch (err) {
    console.error(`--keys ${dir}: ${err.message}`)
    process.exit(2)
  }
}

module.exports = { curveOptions }

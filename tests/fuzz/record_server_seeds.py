#!/usr/bin/env python3
"""Records what clients send to sculptd, as seeds for the server_message fuzzer.

  record_server_seeds.py SCULPTD SCULPTCTL tests/fuzz/server_seeds FAKE_SCULPTD

Starts sculptd on a replayed recording, puts a proxy socket in front of it and
runs sculptctl commands through the proxy; each connection's client→daemon
bytes become one seed file (hello, status, devices, keyframe, control calls).
Then the same in front of FAKE_SCULPTD (build/tests/unit/server/fake_sculptd:
the server on a fake daemon with a history and an export to read) for undo,
redo, history and export (its chunked reads included).
"""
import os, socket, subprocess, sys, tempfile, threading, time

sculptd, sculptctl, outdir, fake_sculptd = sys.argv[1:5]
recordings = os.path.join(os.path.dirname(os.path.abspath(__file__)), '..', 'data', 'recordings')
tmp = tempfile.mkdtemp()
real, proxy = os.path.join(tmp, 'real.sock'), os.path.join(tmp, 'proxy.sock')
d = subprocess.Popen([sculptd, '--scene', 'builtin:default', '--socket', real, '--duration', '30',
                      '--input', 'replay:' + os.path.join(recordings, 'push.jsonl')], stderr=subprocess.DEVNULL)
while not os.path.exists(real):
    time.sleep(0.05)
time.sleep(0.3)

def pump(src, dst, log):
    try:
        while True:
            b = src.recv(65536)
            if not b:
                break
            if log is not None:
                log.append(b)
            dst.sendall(b)
    except OSError:
        pass
    try:
        dst.shutdown(socket.SHUT_WR)
    except OSError:
        pass

def serve_one(listener, name, target):
    c, _ = listener.accept()
    s = socket.socket(socket.AF_UNIX)
    s.connect(target)
    sent = []
    t1 = threading.Thread(target=pump, args=(c, s, sent))
    t2 = threading.Thread(target=pump, args=(s, c, None))
    t1.start(); t2.start(); t1.join(); t2.join()
    with open(os.path.join(outdir, name), 'wb') as f:
        f.write(b''.join(sent))

def record(target, seeds):
    if os.path.exists(proxy):
        os.unlink(proxy)
    listener = socket.socket(socket.AF_UNIX)
    listener.bind(proxy)
    listener.listen(4)
    for name, args in seeds:
        t = threading.Thread(target=serve_one, args=(listener, name, target))
        t.start()
        subprocess.run([sculptctl] + args + ['--socket', proxy], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        t.join()
    listener.close()

record(real, [('hello_status', ['status']), ('devices', ['devices']), ('pause', ['pause']),
              ('resume', ['resume']), ('reset', ['reset']), ('load_bad', ['load', '/nonexistent.toml']),
              ('keyframe', ['save', os.path.join(tmp, 'x.obj')])])
d.terminate()
d.wait()

fake_socket = os.path.join(tmp, 'fake.sock')
f = subprocess.Popen([fake_sculptd, fake_socket])
while not os.path.exists(fake_socket):
    time.sleep(0.05)
record(fake_socket, [('undo', ['undo', '3']), ('redo', ['redo']), ('history', ['history', '--json']),
                     ('export', ['export', os.path.join(tmp, 'x.sculpt')])])
f.terminate()
f.wait()

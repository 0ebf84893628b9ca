#!/usr/bin/python3
"""An image campaign watched through its live page, with and without misbehaving clients.

Runs `gonio acquire --mode image --serve 127.0.0.1:0` on the embedded virtual rig four times
(quiet, flooded, quiet, flooded) and prints the light positions per second from the first frame to
the end. Flooded: once the URL is printed, 200 connections that send nothing and one client with a
4 KB receive buffer that requests the frame picture 200 times and never reads.

    flock /tmp/gonio-gige.lock /usr/bin/python3 bench/live_page_flood.py [build/tools/gonio]
"""
import os
import re
import shutil
import socket
import subprocess
import sys
import tempfile
import time

exe = sys.argv[1] if len(sys.argv) > 1 else "build/tools/gonio"


def run(flood):
    out = os.path.join(work, "c%d" % flood)
    shutil.rmtree(out, ignore_errors=True)
    p = subprocess.Popen([exe, "acquire", "--mode", "image", "--serve", "127.0.0.1:0", "--out", out,
                          "--coverage-target", "0.45", "--max-frames", "40", "--time-scale", "1"],
                         stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    socks = []; lines = []; first = None
    for line in p.stdout:
        lines.append(line)
        m = re.search(r"live page: http://127.0.0.1:(\d+)/", line)
        if m:
            port = int(m.group(1))
            if flood:
                for i in range(200):
                    s = socket.create_connection(("127.0.0.1", port)); socks.append(s)
                sink = socket.socket(); sink.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4096)
                sink.connect(("127.0.0.1", port)); sink.setblocking(False); socks.append(sink)
                req = b"GET /img/frame.png HTTP/1.1\r\nHost: x\r\n\r\n"
                try:
                    for i in range(200): sink.send(req)
                except BlockingIOError: pass
        if line.startswith("frame 1:"): first = time.time()
    p.wait(); t1 = time.time()
    frames = sum(1 for l in lines if l.startswith("frame "))
    print("flood" if flood else "quiet", "exit", p.returncode, "frames", frames,
          "seconds from frame 1 to end %.1f" % (t1 - first), "frames/s %.3f" % ((frames - 1) / (t1 - first)))
    for s in socks: s.close()


work = tempfile.mkdtemp(prefix="live_page_flood_")
for f in (0, 1, 0, 1): run(f)

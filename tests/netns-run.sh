#!/bin/sh
# Runs one test command in a network namespace of its own (root only), with its own loopback up.
#
# The tests that stream camera frames through Aravis need it: run as root, Aravis 0.8 receives GVSP
# through a packet socket that sees every loopback datagram until its filter is attached, and GigE
# Vision control uses the fixed UDP port 3956 on 127.0.0.1. In a namespace of its own a test sees no
# other test's traffic and owns port 3956, so these tests run in parallel like the others.
# GONIO_TEST_NETNS=1 tells a test that it is alone on its loopback (no machine-wide lock needed).
exec unshare --net -- sh -c 'ip link set lo up && GONIO_TEST_NETNS=1 exec "$@"' netns-run "$@"

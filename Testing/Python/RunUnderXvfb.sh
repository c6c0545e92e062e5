#!/usr/bin/env bash
# Runs a command with DISPLAY set to a virtual X server of its own, and stops that server (and
# waits for it) when the command ends.
# Usage: RunUnderXvfb.sh COMMAND ARGUMENTS...
#
# Not xvfb-run -a, which python.state_all_filters failed under in CI ("bad X server connection.
# DISPLAY=:100"): it takes the first display number without a lock file, so a test starting
# while another one's server is still going away (xvfb-run does not wait for it) can take that
# number, and its clients then reach the old server. Xvfb -displayfd searching from :0 has the
# same trouble here: with four tests in parallel, one in six starts failed with "could not
# connect to display" after the server had reported itself ready. So:
#  - a random display number between 1000 and 30999, which the next test is unlikely to take;
#  - the server is ready when it writes its number to -displayfd, and usable only when a client
#    has opened a connection to it, so a failed start is retried on another number;
#  - -noreset, or the server resets when its last client disconnects, and a client connecting in
#    that moment (ParaView opens several connections) is refused.
set -u
xvfb_executable="${STM_XVFB:-Xvfb}"
work_dir=$(mktemp -d "${TMPDIR:-/tmp}/stm-xvfb.XXXXXX")
log_file="$work_dir/xvfb.log"
xvfb_pid=""
command_pid=""

stop_server() {
  if [ -n "$command_pid" ]; then
    kill "$command_pid" 2>/dev/null
  fi
  if [ -n "$xvfb_pid" ]; then
    kill "$xvfb_pid" 2>/dev/null
    wait "$xvfb_pid" 2>/dev/null
    xvfb_pid=""
  fi
}
# Stops the server, removes the work folder and exits with status $1.
finish() {
  stop_server
  rm -rf "$work_dir"
  exit "$1"
}
trap 'finish 143' TERM
trap 'finish 130' INT

# Opens and closes one connection with Xlib, as every client here does.
can_connect() {
  DISPLAY="$1" python3 -c '
import ctypes, sys
xlib = ctypes.CDLL("libX11.so.6")
xlib.XOpenDisplay.restype = ctypes.c_void_p
xlib.XCloseDisplay.argtypes = [ctypes.c_void_p]
display = xlib.XOpenDisplay(None)
if not display:
    sys.exit(1)
xlib.XCloseDisplay(display)
'
}

# Starts a server on display $1; succeeds when a client can connect to it within 30 s.
start_server() {
  local display_file="$work_dir/display"
  : >"$display_file"
  "$xvfb_executable" ":$1" -displayfd 3 -noreset -nolisten tcp -screen 0 1280x1024x24 \
    3>"$display_file" >>"$log_file" 2>&1 &
  xvfb_pid=$!
  for _ in $(seq 300); do
    if [ "$(wc -l <"$display_file")" -ge 1 ]; then
      can_connect ":$1" && return 0
      break
    fi
    if ! kill -0 "$xvfb_pid" 2>/dev/null; then
      break
    fi
    sleep 0.1
  done
  stop_server
  return 1
}

display_number=""
for attempt in 1 2 3 4 5 6 7 8; do
  candidate=$((1000 + RANDOM % 30000))
  echo "attempt $attempt on :$candidate" >>"$log_file"
  if start_server "$candidate"; then
    display_number="$candidate"
    break
  fi
done
if [ -z "$display_number" ]; then
  echo "RunUnderXvfb: no virtual X server ($xvfb_executable) started in 8 attempts:" >&2
  cat "$log_file" >&2
  finish 1
fi

export DISPLAY=":$display_number"
"$@" &
command_pid=$!
# Waiting on a background command lets the TERM trap stop the server when ctest's timeout fires.
wait "$command_pid"
status=$?
command_pid=""
if [ "$status" -ne 0 ]; then
  echo "RunUnderXvfb: the command failed (status $status) on DISPLAY=$DISPLAY; the server said:" >&2
  cat "$log_file" >&2
fi
finish "$status"

#!/usr/bin/env bash
# lcm-spy that decodes every dynfilter channel: puts build/lcmtypes/dynfilter_lcmtypes.jar
# on CLASSPATH (lcm-spy finds types only there) and starts the lcm wheel's lcm-spy, which
# runs on Java 17 (Debian's launcher passes -Xincgc and does not start).
#
#   tools/lcm-spy.sh [lcm-spy options, e.g. --lcm-url udpm://239.255.76.67:7667?ttl=0]
#
# The LCM URL defaults to $LCM_DEFAULT_URL, as for every LCM program. Needs a display
# (X11); on a headless machine: xvfb-run -a tools/lcm-spy.sh.
# Environment: DYNFILTER_BUILD_DIR (default <repo>/build), DYNFILTER_LCM_VENV (default
# $DYNFILTER_BUILD_DIR/venv, made by tools/install-deps.sh).
set -euo pipefail
repo="$(cd "$(dirname "$0")/.." && pwd)"
build="${DYNFILTER_BUILD_DIR:-$repo/build}"
venv="${DYNFILTER_LCM_VENV:-$build/venv}"
types_jar="$build/lcmtypes/dynfilter_lcmtypes.jar"

if [ ! -f "$types_jar" ]; then
  echo "lcm-spy.sh: $types_jar not found: build first (cmake --build $build); it needs" \
       "javac and jar (default-jdk-headless) and the lcm wheel (tools/install-deps.sh)" >&2
  exit 1
fi
# A jar older than the message definitions shows their channels as undecodable.
for lcm_file in "$repo"/lcmtypes/*.lcm; do
  if [ "$lcm_file" -nt "$types_jar" ]; then
    echo "lcm-spy.sh: $types_jar is older than $lcm_file: rebuild (cmake --build $build)" >&2
    exit 1
  fi
done

export CLASSPATH="$types_jar${CLASSPATH:+:$CLASSPATH}"

if [ -x "$venv/bin/lcm-spy" ]; then
  exec "$venv/bin/lcm-spy" "$@"
fi
# No venv: the wheel's jars elsewhere, or Debian's liblcm-java with jchart2d, run directly.
lcm_jar=""
for candidate in "$venv"/lib/python3*/site-packages/share/java/lcm.jar /usr/share/java/lcm.jar; do
  if [ -f "$candidate" ]; then lcm_jar="$candidate"; break; fi
done
if [ -z "$lcm_jar" ]; then
  echo "lcm-spy.sh: no lcm-spy: run tools/install-deps.sh (it installs the lcm wheel into $venv)" >&2
  exit 1
fi
java_dir="$(dirname "$lcm_jar")"
classpath="$lcm_jar"
for dep in jchart2d-3.2.2.jar xmlgraphics-commons-1.3.1.jar jide-oss-2.9.7.jar; do
  for dir in "$java_dir" /usr/share/java; do
    if [ -f "$dir/$dep" ]; then classpath="$classpath:$dir/$dep"; break; fi
  done
done
exec java -Djava.net.preferIPv4Stack=true -Xmx128m -ea -cp "$classpath:$CLASSPATH" lcm.spy.Spy "$@"

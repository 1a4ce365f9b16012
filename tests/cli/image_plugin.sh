#!/usr/bin/env bash
# The lcm-spy image plugin (lcmtypes/java/sirupp/spy/ImagePlugin.java, in the types jar), without a
# display: compiles tests/java/ImagePluginTest.java against the jar and runs it headless. Run by
# CTest from the source root with the jar's path.
set -u
jar_file=$1
classpath="$jar_file:/usr/share/java/lcm.jar"
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
javac -Xlint:all -Werror -d "$work" -cp "$classpath" tests/java/ImagePluginTest.java ||
  { echo "image_plugin: FAILED (the test does not compile)"; exit 1; }
java -Djava.awt.headless=true -cp "$work:$classpath" ImagePluginTest || { echo "image_plugin: FAILED"; exit 1; }

#!/usr/bin/env bash
# System packages the integration tests start themselves (a Mosquitto per test, an influxd per
# test, a PostgreSQL cluster, ...), and RabbitMQ's MQTT adapter (the seed's ground broker) on
# 127.0.0.1:1884.
# Installed from Debian by name when missing; nothing is downloaded from anywhere else.
# Idempotent and quick when everything is already in place.
set -euo pipefail
need=()
command -v mosquitto >/dev/null 2>&1 || [ -x /usr/sbin/mosquitto ] || need+=(mosquitto)
command -v influxd >/dev/null 2>&1 || [ -x /usr/bin/influxd ] || need+=(influxdb)
# PostgreSQL for the ground replicas' shared state (issue 27): the tests use the machine's server
# on 127.0.0.1:5432 and start clusters of their own with its initdb and pg_ctl.
ls /usr/lib/postgresql/*/bin/initdb >/dev/null 2>&1 || need+=(postgresql)
# Debian's Chromium for the web apps' end-to-end tests (tests/e2e; Playwright cannot download one).
[ -x /usr/bin/chromium ] || need+=(chromium)
if [ ${#need[@]} -gt 0 ]; then
  if [ "$(id -u)" = 0 ]; then
    # Install without starting the packaged daemons: the tests start their own on free ports.
    made_policy=0
    if [ ! -e /usr/sbin/policy-rc.d ]; then
      printf '#!/bin/sh\nexit 101\n' >/usr/sbin/policy-rc.d
      chmod +x /usr/sbin/policy-rc.d
      made_policy=1
    fi
    apt-get update -qq
    DEBIAN_FRONTEND=noninteractive apt-get install -y -qq "${need[@]}" || rc=$?
    [ "$made_policy" = 1 ] && rm -f /usr/sbin/policy-rc.d
    [ "${rc:-0}" = 0 ] || exit "$rc"
  else
    echo "missing system packages: ${need[*]} (install them with apt-get as root)" >&2
    exit 1
  fi
fi

# --- RabbitMQ MQTT adapter on 127.0.0.1:1884 ------------------------------------------------
# Mosquitto already holds 127.0.0.1:1883, so the plugin must listen elsewhere. Two parts:
#  1. rabbitmq.conf gets the listener (so a RabbitMQ restart keeps it);
#  2. the running node gets the same settings through `rabbitmqctl eval` *before* the plugin is
#     enabled online, so no broker restart is needed (a restart would cut other users off).
# Skipped quietly when RabbitMQ is not installed or not running (the RabbitMQ tests then skip).
RABBIT_MQTT_PORT="${RABBIT_MQTT_PORT:-1884}"
if command -v rabbitmqctl >/dev/null 2>&1 && [ "$(id -u)" = 0 ]; then
  conf=/etc/rabbitmq/rabbitmq.conf
  if [ -d /etc/rabbitmq ] && ! grep -q '^mqtt.listeners.tcp' "$conf" 2>/dev/null; then
    {
      echo "# dronefleet: MQTT adapter beside Mosquitto's 1883 (scripts/system-deps.sh)"
      echo "mqtt.listeners.tcp.default = 127.0.0.1:${RABBIT_MQTT_PORT}"
      echo "mqtt.allow_anonymous = false"
    } >>"$conf"
  fi
  # No anonymous MQTT client, ever (issue 25): an anonymous CONNECT landed as guest and, with a
  # client id it knew, cut that client off in another vhost. Earlier set-ups wrote "true".
  [ -f "$conf" ] && sed -i 's/^mqtt.allow_anonymous = true$/mqtt.allow_anonymous = false/' "$conf"
  if timeout 20 rabbitmqctl -q status >/dev/null 2>&1; then
    if ! (exec 3<>"/dev/tcp/127.0.0.1/${RABBIT_MQTT_PORT}") 2>/dev/null; then
      timeout 20 rabbitmqctl -q eval "application:load(rabbitmq_mqtt),
        application:set_env(rabbitmq_mqtt, tcp_listeners, [{\"127.0.0.1\", ${RABBIT_MQTT_PORT}}]),
        application:set_env(rabbitmq_mqtt, allow_anonymous, false)." >/dev/null
      timeout 60 rabbitmq-plugins -q enable rabbitmq_mqtt >/dev/null
    fi
    timeout 20 rabbitmqctl -q eval \
      "application:set_env(rabbitmq_mqtt, allow_anonymous, false)." >/dev/null
  fi
fi

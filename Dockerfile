# xarm-emu control box emulator: `xarm-emu serve` on all interfaces, command port 502 and report
# ports 30001-30003 (Developer Manual V1.6.0, 2.1 and 2.2). See docs/container.md.
#
#   docker build -t xarm-emu .                                   # wheels from the package index
#   docker build --build-arg BASE=my-debian-python -t xarm-emu . # another base with python3 + venv
#
# Stage 1 builds (or takes from build/wheels, built on the host) every wheel; stage 2 installs
# them offline into a venv; the runtime stage copies that venv alone: no compilers, no pip, no
# test dependencies.
ARG BASE=python:3.11-slim

FROM ${BASE} AS wheels
COPY pyproject.toml README.md /src/
COPY src /src/src
# build/wheels is optional: the pattern may match nothing, pyproject.toml always matches.
COPY pyproject.toml build/wheel[s] /wheels/
RUN set -e; mkdir -p /wheels; \
    if ! ls /wheels/xarm_emu-*.whl >/dev/null 2>&1; then \
        python3 -m venv /tmp/build && /tmp/build/bin/pip wheel --quiet --wheel-dir /wheels /src; \
    fi

FROM ${BASE} AS venv
COPY --from=wheels /wheels /wheels
RUN python3 -m venv --copies /opt/xarm-emu \
 && /opt/xarm-emu/bin/python -m pip install --quiet --no-index --find-links /wheels --no-cache-dir xarm-emu \
 && /opt/xarm-emu/bin/python -m pip uninstall --quiet --yes pip setuptools \
 && rm -rf /wheels /opt/xarm-emu/lib/python3*/site-packages/numpy/*/tests \
 && cd /opt/xarm-emu/bin && for f in python python3; do [ -L "$f" ] || ln -sf python3.*[0-9] "$f"; done

FROM ${BASE}
COPY --from=venv /opt/xarm-emu /opt/xarm-emu
COPY scripts/container-health /usr/local/bin/xarm-emu-health
# A non-root user that can still bind port 502: a file capability (cap_net_bind_service) on the
# venv's own copy of the interpreter, written as the security.capability attribute (VFS cap
# revision 2, effective bit). A sysctl (net.ipv4.ip_unprivileged_port_start) would not do here:
# it belongs to a network namespace, and Docker refuses it for --network host containers.
RUN set -e; chmod 0755 /usr/local/bin/xarm-emu-health; \
    (useradd --system --uid 10502 --home-dir /var/lib/xarm-emu --shell /usr/sbin/nologin xarm \
     || adduser --system --uid 10502 --home /var/lib/xarm-emu --shell /usr/sbin/nologin xarm); \
    mkdir -p /var/lib/xarm-emu && chown 10502:0 /var/lib/xarm-emu && chmod 0770 /var/lib/xarm-emu; \
    for f in /opt/xarm-emu/bin/python3.*[0-9]; do /opt/xarm-emu/bin/python -c \
      "import os, struct, sys; os.setxattr(sys.argv[1], 'security.capability', struct.pack('<5I', 0x02000001, 1 << 10, 0, 0, 0))" "$f"; \
    done
ENV PATH=/opt/xarm-emu/bin:$PATH \
    PYTHONDONTWRITEBYTECODE=1 \
    XARM_EMU_SERVE_HOST=0.0.0.0 \
    XARM_EMU_SERVE_CONFIG_DIR=/var/lib/xarm-emu
USER 10502
WORKDIR /var/lib/xarm-emu
VOLUME ["/var/lib/xarm-emu"]
EXPOSE 502 30001 30002 30003
# Ready once the command port answers the protocol (xarm-emu status --wait).
HEALTHCHECK --interval=1s --timeout=5s --start-period=30s --retries=3 CMD ["/usr/local/bin/xarm-emu-health"]
# Exec form: the emulator is PID 1 and closes cleanly on SIGTERM (docker stop).
STOPSIGNAL SIGTERM
ENTRYPOINT ["/opt/xarm-emu/bin/xarm-emu", "serve"]

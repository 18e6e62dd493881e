# SPDX-License-Identifier: Apache-2.0
"""Servers on 127.0.0.1 for the remote cache benchmarks (bench/remote_transfers.py, bench/remote_faults.py): a free
port, waiting until something listens, and Debian's nginx with WebDAV PUT in a directory of the caller's, in the
foreground, stopped by the caller through the returned process."""
import os
import socket
import subprocess
import sys
import time


def free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def wait_listening(port):
    for _ in range(400):
        try:
            socket.create_connection(("127.0.0.1", port), timeout=0.2).close()
            return
        except OSError:
            time.sleep(0.025)
    sys.exit(f"nothing listens on {port}")


def start_nginx(work, name="server", location=""):
    """nginx serving <work>/<name>/data; `location` adds directives to `location /`. Returns (process, port, data)."""
    port = free_port()
    server = os.path.join(work, name)
    for d in ("data", "tmp"):
        os.makedirs(os.path.join(server, d), exist_ok=True)
    conf = os.path.join(server, "nginx.conf")
    with open(conf, "w") as f:
        f.write(f"""daemon off; master_process off; worker_processes 1; pid {server}/nginx.pid; error_log {server}/error.log;
events {{ worker_connections 512; }}
http {{ access_log off; client_body_temp_path {server}/tmp/body; proxy_temp_path {server}/tmp/proxy;
  fastcgi_temp_path {server}/tmp/fastcgi; uwsgi_temp_path {server}/tmp/uwsgi; scgi_temp_path {server}/tmp/scgi;
  client_max_body_size 512m; keepalive_requests 100000;
  server {{ listen 127.0.0.1:{port} backlog=512; root {server}/data;
    location / {{ dav_methods PUT; create_full_put_path on; dav_access user:rw; {location} }} }} }}
""")
    proc = subprocess.Popen(["/usr/sbin/nginx", "-p", server + "/", "-c", conf, "-e", os.path.join(server, "error.log")])
    wait_listening(port)
    return proc, port, os.path.join(server, "data")

# Tessera in one small image: the static `tessera` binary alone, usable as coordinator or worker.
#
# Build with `make image` (or deploy/build-image.sh): it compiles the static binary first, then
# builds this file from a context holding only that binary, so nothing is pulled and the engine
# needs no base image. There is no shell and no curl inside: probes run `tessera healthcheck`.
FROM scratch
COPY tessera /tessera
# Empty directories owned by the unprivileged user: the coordinator's data dir (mount a volume
# here; a new named volume takes this ownership) and a temp dir for `tessera render`.
COPY --chown=65534:65534 data /data
COPY --chown=65534:65534 tmp /tmp
USER 65534:65534
ENV TESSERA_DATA=/data \
    TESSERA_LISTEN=0.0.0.0:7878 \
    TMPDIR=/tmp
EXPOSE 7878
ENTRYPOINT ["/tessera"]
CMD ["--help"]

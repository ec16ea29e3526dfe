# suture_fem on Debian, installed by the same script as the README (scripts/install.sh), on either
# supported release:
#   docker build -t suture-fem .                                     # Debian 13 trixie (default)
#   docker build --build-arg DEBIAN_RELEASE=bookworm -t suture-fem:bookworm .
#   docker run --rm -v "$PWD/results:/work/results" suture-fem      # the main job -> ./results/paper
# README "Docker" has more (MPI inside the container, the test suite). scripts/test-container.sh
# RELEASE is the test of this file: it builds it with a real engine and runs the main job, a 2-rank
# run and a test subset inside the image; scripts/test-release.sh RELEASE runs the same install
# script in a fresh minimal root of the release.
ARG DEBIAN_RELEASE=trixie
FROM debian:${DEBIAN_RELEASE}
ENV DEBIAN_FRONTEND=noninteractive \
    OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 \
    OMP_NUM_THREADS=1 OMPI_MCA_btl=^tcp \
    PYVISTA_OFF_SCREEN=true
WORKDIR /opt/suture_fem
# The Debian packages first, in a layer of their own: a change to the project's files rebuilds only
# the layers below, not the ~1 GB of packages.
COPY scripts/install.sh scripts/
RUN bash scripts/install.sh --apt-only && rm -rf /var/lib/apt/lists/*
COPY . .
RUN bash scripts/install.sh && rm -rf /root/.cache/pip
# Docker's default seccomp profile refuses the single-copy read (CMA) of Open MPI's shared-memory
# transport: Open MPI 4.1 then prints "Read -1, expected N, errno = 1" on every message. Off here,
# so `mpirun` inside the container needs no extra option.
ENV PATH=/opt/suture_fem/.venv/bin:$PATH \
    OMPI_MCA_btl_vader_single_copy_mechanism=none
WORKDIR /work
ENTRYPOINT ["suture-fem"]
CMD ["run", "paper", "--out", "/work/results/paper"]

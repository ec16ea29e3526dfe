# suture_fem on Debian, installed by the same script as the README (scripts/install.sh), on either
# supported release:
#   docker build -t suture-fem .                                     # Debian 13 trixie (default)
#   docker build --build-arg DEBIAN_RELEASE=bookworm -t suture-fem:bookworm .
# scripts/test-release.sh RELEASE is the test of this recipe: it runs the same script in a fresh
# minimal root of the same release and then the README's commands and the tests inside it.
ARG DEBIAN_RELEASE=trixie
FROM debian:${DEBIAN_RELEASE}
ENV DEBIAN_FRONTEND=noninteractive \
    OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 \
    OMP_NUM_THREADS=1 OMPI_MCA_btl=^tcp \
    PYVISTA_OFF_SCREEN=true
WORKDIR /opt/suture_fem
COPY . .
RUN bash scripts/install.sh && rm -rf /var/lib/apt/lists/*
ENV PATH=/opt/suture_fem/.venv/bin:$PATH
WORKDIR /work
ENTRYPOINT ["suture-fem"]
CMD ["run", "paper", "--out", "/work/results/paper"]

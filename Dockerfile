# suture_fem on the same Debian release the tests run on, installed by the same script as the README.
FROM debian:bookworm
ENV DEBIAN_FRONTEND=noninteractive \
    OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 \
    PYVISTA_OFF_SCREEN=true
WORKDIR /opt/suture_fem
COPY . .
RUN bash scripts/install.sh && rm -rf /var/lib/apt/lists/*
ENV PATH=/opt/suture_fem/.venv/bin:$PATH
WORKDIR /work
ENTRYPOINT ["suture-fem"]
CMD ["run", "paper", "--out", "/work/results/paper"]

# ctest python_client_install: a fresh venv in WORK_DIR with the Python client installed from a copy of
# the checkout's client/python and proto/ (same layout, so setup.py finds ../../proto; the copy keeps
# pip's in-tree build files out of the source tree). Offline: no index, no build isolation, no deps
# (those come from the system site-packages). Then, best effort and the one step that reaches PyPI, the
# package's "typecheck" extra (mypy and the grpc and protobuf stubs, which Debian 12 does not package)
# for test_typing.py's `mypy --strict`: without it (offline) that test skips, saying what is missing.
#   cmake -DPYTHON=python3 -DSOURCE_DIR=<checkout> -DWORK_DIR=<dir> -P install_client.cmake
foreach(var PYTHON SOURCE_DIR WORK_DIR)
  if(NOT ${var})
    message(FATAL_ERROR "install_client.cmake: -D${var}=... is required")
  endif()
endforeach()

set(stage ${WORK_DIR}/stage)
set(venv ${WORK_DIR}/venv)
file(REMOVE_RECURSE ${stage} ${venv})
file(COPY ${SOURCE_DIR}/client/python DESTINATION ${stage}/client
     REGEX "/squall/v1$" EXCLUDE PATTERN "build" EXCLUDE PATTERN "*.egg-info" EXCLUDE PATTERN "__pycache__" EXCLUDE
     PATTERN "proto" EXCLUDE)
file(COPY ${SOURCE_DIR}/proto/squall DESTINATION ${stage}/proto)

function(run)
  execute_process(COMMAND ${ARGN} RESULT_VARIABLE status)
  if(NOT status EQUAL 0)
    message(FATAL_ERROR "failed (${status}): ${ARGN}")
  endif()
endfunction()

run(${PYTHON} -m venv --system-site-packages ${venv})
run(${CMAKE_COMMAND} -E env PIP_DISABLE_PIP_VERSION_CHECK=1 PIP_NO_INPUT=1
    ${venv}/bin/python -m pip install --no-build-isolation --no-deps --no-index ${stage}/client/python)
run(${venv}/bin/python -c "import squall, squall.aio, squall.v1.ocean_pb2_grpc; print('squall', squall.__version__, 'from', squall.__file__)")

# The versions test_typing.py was last checked with (within the extra's ranges in pyproject.toml):
# pinned, so that a new mypy release cannot fail the suite by itself.
set(typecheck mypy==2.4.1 types-grpcio==1.85.0.20261028 types-protobuf==7.35.1.20260906)
execute_process(COMMAND ${CMAKE_COMMAND} -E env PIP_DISABLE_PIP_VERSION_CHECK=1 PIP_NO_INPUT=1
                        ${venv}/bin/python -m pip install -q --retries 0 --timeout 30 ${typecheck}
                RESULT_VARIABLE status)
if(NOT status EQUAL 0)
  string(REPLACE ";" " " typecheck "${typecheck}")
  message(WARNING "install_client.cmake: the typecheck extra (${typecheck}) was not installed from "
                  "PyPI (${status}): test_typing.py will skip")
endif()

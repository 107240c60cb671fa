# The container image (deploy/container): built from the local Debian base, two read-only non-root
# containers behind Envoy, a tile through the proxy compared bit for bit with the host build's. Label
# "long" (it compiles squalld in the image: minutes): `ctest -LE long` skips it; CI runs it. Exit 77:
# skipped, with the reason printed (podman cannot run containers on that machine).
add_test(NAME container_image_test
         COMMAND ${CMAKE_CURRENT_SOURCE_DIR}/container_test.sh ${CMAKE_SOURCE_DIR} $<TARGET_FILE:squalld>
                 $<TARGET_FILE:squall> ${SQUALL_TOOLS} ${CMAKE_CURRENT_BINARY_DIR}/container)
set_tests_properties(container_image_test PROPERTIES LABELS long TIMEOUT 2400 SKIP_RETURN_CODE 77
  ENVIRONMENT "POCL_CACHE_DIR=${SQUALL_TEST_CACHE_DIR}")

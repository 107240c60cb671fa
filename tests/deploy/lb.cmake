# The proxies in front of several replicas (deploy/lb): the shipped configurations are the generator's
# output and pass the proxies' own checks (lb_config_test); three squalld behind Envoy and behind nginx
# with a drain mid-run (replicas_envoy_test, replicas_nginx_test; pytest in the Python client's venv).
add_test(NAME lb_config_test COMMAND ${CMAKE_CURRENT_SOURCE_DIR}/check_lb_config.sh ${CMAKE_SOURCE_DIR} ${SQUALL_TOOLS}
         ${CMAKE_CURRENT_BINARY_DIR}/lb-config)
set_tests_properties(lb_config_test PROPERTIES TIMEOUT 120)

foreach(proxy envoy nginx)
  add_test(NAME replicas_${proxy}_test
           COMMAND ${CMAKE_BINARY_DIR}/tests/python/venv/bin/python -m pytest -q -p no:cacheprovider -k ${proxy}
                   ${CMAKE_CURRENT_SOURCE_DIR}/test_replicas.py
           WORKING_DIRECTORY ${CMAKE_CURRENT_BINARY_DIR})
  set_tests_properties(replicas_${proxy}_test PROPERTIES TIMEOUT 900 FIXTURES_REQUIRED squall_python
    ENVIRONMENT "SQUALL_SQUALLD=$<TARGET_FILE:squalld>;SQUALL_SOURCE_DIR=${CMAKE_SOURCE_DIR};SQUALL_BINARY_DIR=${CMAKE_BINARY_DIR};SQUALL_TOOLS=${SQUALL_TOOLS};PYTHONDONTWRITEBYTECODE=1")
endforeach()

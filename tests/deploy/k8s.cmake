# The Kubernetes manifests (deploy/k8s): every overlay rendered by kubectl kustomize, validated offline
# with kubernetes-validate --strict, and checked for probes, limits, security context, the drain's
# grace period and the shared state volume (check_manifests.py, in the deployment tools' venv).
add_test(NAME k8s_manifests_test
         COMMAND ${SQUALL_TOOLS}/bin/python ${CMAKE_CURRENT_SOURCE_DIR}/check_manifests.py ${CMAKE_SOURCE_DIR}
                 ${SQUALL_TOOLS} ${CMAKE_CURRENT_BINARY_DIR}/k8s)
set_tests_properties(k8s_manifests_test PROPERTIES TIMEOUT 300 ENVIRONMENT "PYTHONDONTWRITEBYTECODE=1")

cmake_minimum_required(VERSION 3.25)
# The layering rules, checked on the sources (cmake -P, run by ctest as layering_test):
#  1. daemon/ is the composition root: no file outside server/daemon/ includes "daemon/...".
#  2. A capability's folder (server/<capability>/) includes no other capability's service (a request
#     translator may use another's when its proto imports that one's messages: eWave's ambient ocean).
#  3. server/rpc/ includes no capability: capabilities plug into it, not the other way round.
#  4. The engine library links no gRPC or protobuf (ENGINE_LINKS, computed at configure time), and none of
#     its sources (ENGINE_SOURCES) includes, directly or through the headers it includes, a gRPC,
#     protobuf or RPC-layer header.
# Arguments: -DSOURCE_DIR=... -DENGINE_SOURCES=<file listing sources> -DENGINE_LINKS=<file listing links>
set(violations "")

file(GLOB_RECURSE all_files RELATIVE ${SOURCE_DIR}
     ${SOURCE_DIR}/server/*.h ${SOURCE_DIR}/server/*.cpp ${SOURCE_DIR}/client/*.h ${SOURCE_DIR}/client/*.cpp
     ${SOURCE_DIR}/bench/*.h ${SOURCE_DIR}/bench/*.cpp ${SOURCE_DIR}/tests/*.h ${SOURCE_DIR}/tests/*.cpp)
file(GLOB capability_dirs LIST_DIRECTORIES true RELATIVE ${SOURCE_DIR}/server ${SOURCE_DIR}/server/*)
set(capabilities "")
foreach(dir ${capability_dirs})
  if(EXISTS ${SOURCE_DIR}/server/${dir}/CMakeLists.txt)
    list(APPEND capabilities ${dir})
  endif()
endforeach()

foreach(f ${all_files})
  file(STRINGS ${SOURCE_DIR}/${f} includes REGEX "^#include \"")
  if(NOT f MATCHES "^server/daemon/" AND includes MATCHES "#include \"daemon/")
    list(APPEND violations "${f} includes daemon/ (the composition root)")
  endif()
  foreach(cap ${capabilities})
    if(f MATCHES "^server/rpc/" AND includes MATCHES "#include \"${cap}/")
      list(APPEND violations "${f} (the RPC layer) includes the ${cap} capability")
    endif()
    if(f MATCHES "^server/${cap}/")
      foreach(other ${capabilities})
        if(NOT other STREQUAL cap AND includes MATCHES "#include \"${other}/[a-z_]*_service\\.h\"")
          list(APPEND violations "${f} includes the ${other} capability's service")
        endif()
      endforeach()
    endif()
  endforeach()
endforeach()

file(STRINGS ${ENGINE_LINKS} links)
foreach(link ${links})
  if(link MATCHES "grpc|protobuf|squall_proto|squall_rpc")
    list(APPEND violations "squall_engine links ${link}")
  endif()
endforeach()
# The quoted includes of the engine's sources, followed through the headers under server/ and kernels/.
file(STRINGS ${ENGINE_SOURCES} sources)
set(queue ${sources})
set(seen "")
while(queue)
  list(POP_FRONT queue file)
  if(file IN_LIST seen OR NOT EXISTS "${file}")
    continue()
  endif()
  list(APPEND seen ${file})
  file(STRINGS ${file} includes REGEX "^#include")
  if(includes MATCHES "grpcpp/|\\.pb\\.h|\"rpc/|_service\\.h|_request\\.h|field_codec\\.h")
    list(APPEND violations "engine file ${file} includes a gRPC, protobuf or RPC-layer header")
  endif()
  foreach(line ${includes})
    if(line MATCHES "^#include \"([^\"]+)\"")
      foreach(root ${SOURCE_DIR}/server ${SOURCE_DIR}/kernels)
        if(EXISTS ${root}/${CMAKE_MATCH_1})
          list(APPEND queue ${root}/${CMAKE_MATCH_1})
        endif()
      endforeach()
    endif()
  endforeach()
endwhile()

list(LENGTH all_files checked)
list(LENGTH seen engine_count)
if(violations)
  list(JOIN violations "\n  " text)
  message(FATAL_ERROR "layering violations:\n  ${text}")
endif()
message(STATUS "layering: ${checked} files and ${engine_count} engine files (sources and their headers) follow the rules")

# Installation layout and the Debian package (CPack DEB); docs/deployment.md "Debian package".
# Build it with scripts/build_deb.sh (a separate build configured with HEXA_PACKAGE_LAYOUT=ON,
# so that the binaries' built-in defaults point at the installed files).
set(HEXA_PKG_DIR "${CMAKE_SOURCE_DIR}/deploy/package")
set(HEXA_PKG_DOC "share/doc/hexataar-control")

# Every program of the product (tests/package/check_deb.sh checks the package against the
# hexa_* programs of a build tree and against docs/).
set(HEXA_PKG_PROGRAMS hexa_plant_sim hexa_leg_ctrl hexa_task_space hexa_operator hexa_recorder
    hexa_session hexa_deploy hexa_check_config hexa_sim hexa_calibrate hexa_identify
    hexa_stream_send hexa_teach hexa_washout)
if(TARGET hexa_board_emulator)
  list(APPEND HEXA_PKG_PROGRAMS hexa_board_emulator)
endif()
if(TARGET hexa_bridge)
  list(APPEND HEXA_PKG_PROGRAMS hexa_bridge)
endif()
install(TARGETS ${HEXA_PKG_PROGRAMS} RUNTIME DESTINATION bin)
install(FILES deploy/cyclonedds-loopback.xml deploy/cyclonedds-network.example.xml
        DESTINATION share/hexa)
install(PROGRAMS deploy/make_security.sh DESTINATION share/hexa)
# hexa_recorder report runs <HEXA_SOURCE_DIR>/deploy/plot_session.py (share/hexa when installed).
install(PROGRAMS deploy/plot_session.py DESTINATION share/hexa/deploy)
# hexa_identify runs <HEXA_SOURCE_DIR>/tools/identify/plot_identification.py the same way.
install(PROGRAMS tools/identify/plot_identification.py DESTINATION share/hexa/tools/identify)
install(FILES deploy/foxglove/hexataar.layout.json DESTINATION share/hexa/foxglove)
# hexa_washout's default cue settings: <HEXA_SOURCE_DIR>/deploy/cueing/washout.textproto.
install(FILES deploy/cueing/washout.textproto DESTINATION share/hexa/deploy/cueing)
install(FILES deploy/rigs/hexataar_r.textproto DESTINATION /etc/hexa RENAME rig.textproto)
install(FILES deploy/deployments/five-hosts.textproto "${HEXA_PKG_DIR}/single-host.textproto"
        DESTINATION /etc/hexa/deployments)

# The units of the single-host deployment, generated at build time by hexa_deploy itself (the
# same generator as for networked deployments, whose per-host units go to /etc/systemd/system).
set(HEXA_PKG_GEN "${CMAKE_BINARY_DIR}/package/gen")
set(HEXA_PKG_UNITS hexa-plant.service hexa-supervisor.service hexa-leg1.service
    hexa-leg2.service hexa-leg3.service hexa-leg4.service hexa-leg5.service hexa-leg6.service
    hexa-recorder.service hexa.target)
set(HEXA_PKG_UNIT_FILES "")
foreach(u ${HEXA_PKG_UNITS})
  list(APPEND HEXA_PKG_UNIT_FILES "${HEXA_PKG_GEN}/hosts/local/lib/systemd/system/${u}")
endforeach()
# The deployment is real time: the generator also writes the udev rule that lets the service
# user hold /dev/cpu_dma_latency (docs/deployment.md, "Real time on the target").
set(HEXA_PKG_UDEV_RULE "${HEXA_PKG_GEN}/hosts/local/etc/udev/rules.d/60-hexa-cpu-latency.rules")
add_custom_command(
  OUTPUT ${HEXA_PKG_UNIT_FILES} "${HEXA_PKG_GEN}/hosts/local/etc/hexa/cyclonedds.xml" "${HEXA_PKG_UDEV_RULE}"
  COMMAND "${CMAKE_COMMAND}" -E rm -rf "${HEXA_PKG_GEN}"
  COMMAND hexa_deploy generate "${HEXA_PKG_DIR}/single-host.textproto" --out "${HEXA_PKG_GEN}"
  DEPENDS hexa_deploy "${HEXA_PKG_DIR}/single-host.textproto"
  COMMENT "Generating the units of the single-host deployment")
add_custom_command(
  OUTPUT "${CMAKE_BINARY_DIR}/package/changelog.Debian.gz"
  COMMAND gzip -9n -c "${HEXA_PKG_DIR}/changelog" > "${CMAKE_BINARY_DIR}/package/changelog.Debian.gz"
  DEPENDS "${HEXA_PKG_DIR}/changelog")
add_custom_target(hexa_package_files ALL
  DEPENDS ${HEXA_PKG_UNIT_FILES} "${HEXA_PKG_UDEV_RULE}" "${CMAKE_BINARY_DIR}/package/changelog.Debian.gz")
install(FILES ${HEXA_PKG_UNIT_FILES} DESTINATION /lib/systemd/system)
install(FILES "${HEXA_PKG_GEN}/hosts/local/etc/hexa/cyclonedds.xml" DESTINATION /etc/hexa)
install(FILES "${HEXA_PKG_UDEV_RULE}" DESTINATION /lib/udev/rules.d)
install(FILES README.md "${CMAKE_BINARY_DIR}/package/changelog.Debian.gz"
        DESTINATION ${HEXA_PKG_DOC})
# The manual: every page of docs/ (and its figures), as in the source tree.
install(DIRECTORY docs/ DESTINATION ${HEXA_PKG_DOC}/docs
        FILES_MATCHING PATTERN "*.md" PATTERN "*.png" PATTERN "*.svg" PATTERN "*.csv")

# Manual pages from each program's --help (Debian's help2man), when it is installed.
find_program(HEXA_HELP2MAN help2man)
if(HEXA_HELP2MAN)
  set(HEXA_MAN_PAGES "")
  foreach(entry
      "hexa_plant_sim|simulated HexaTaar rig and clock master"
      "hexa_leg_ctrl|position controller of one leg"
      "hexa_task_space|task-space supervisor of the HexaTaar platform"
      "hexa_operator|send an operator command to the supervisor"
      "hexa_recorder|record, replay, inspect and report HexaTaar sessions"
      "hexa_session|run a complete closed-loop HexaTaar session"
      "hexa_deploy|deployment descriptions to per-host configuration"
      "hexa_check_config|validate a HexaTaar rig file"
      "hexa_bridge|serve a HexaTaar session to Foxglove over WebSocket"
      "hexa_sim|paper trajectories in the in-process HexaTaar simulation"
      "hexa_calibrate|kinematic calibration of a HexaTaar rig from a recording"
      "hexa_identify|identify the pneumatic model of a HexaTaar rig from a recording"
      "hexa_stream_send|send an external motion stream to a HexaTaar supervisor"
      "hexa_teach|teach a HexaTaar trajectory from a recording"
      "hexa_washout|washout cue of a vehicle motion as a HexaTaar trajectory"
      "hexa_board_emulator|emulated remote I/O board of a HexaTaar rig")
    string(REPLACE "|" ";" parts "${entry}")
    list(GET parts 0 prog)
    list(GET parts 1 what)
    if(NOT TARGET ${prog})
      continue()
    endif()
    set(page "${CMAKE_BINARY_DIR}/package/man/${prog}.1")
    add_custom_command(OUTPUT "${page}.gz"
      COMMAND "${CMAKE_COMMAND}" -E make_directory "${CMAKE_BINARY_DIR}/package/man"
      COMMAND "${HEXA_HELP2MAN}" -N --no-discard-stderr --version-string=${PROJECT_VERSION}
              -n "${what}" -o "${page}" $<TARGET_FILE:${prog}>
      COMMAND gzip -9nf "${page}"
      DEPENDS ${prog}
      COMMENT "Manual page of ${prog}")
    list(APPEND HEXA_MAN_PAGES "${page}.gz")
  endforeach()
  add_custom_target(hexa_man_pages ALL DEPENDS ${HEXA_MAN_PAGES})
  install(FILES ${HEXA_MAN_PAGES} DESTINATION share/man/man1)
else()
  message(STATUS "help2man not found: the package will have no manual pages")
endif()

# Every file installed in /etc is a conffile (an administrator's edits survive upgrades).
set(HEXA_PKG_CONFFILES "${CMAKE_BINARY_DIR}/package/conffiles")
file(WRITE "${HEXA_PKG_CONFFILES}"
     "/etc/hexa/rig.textproto\n/etc/hexa/cyclonedds.xml\n"
     "/etc/hexa/deployments/five-hosts.textproto\n/etc/hexa/deployments/single-host.textproto\n")
install(FILES "${HEXA_PKG_DIR}/copyright" DESTINATION ${HEXA_PKG_DOC})

set(CPACK_GENERATOR DEB)
set(CPACK_PACKAGE_NAME hexataar-control)
set(CPACK_PACKAGE_VERSION "${PROJECT_VERSION}")
set(CPACK_DEBIAN_PACKAGE_RELEASE 1)  # not a native package: 0.1.0-1, changelog.Debian.gz
set(CPACK_PACKAGE_CONTACT "HexaTaar control <hexa@localhost>")
set(CPACK_PACKAGE_DESCRIPTION_SUMMARY
    "distributed DDS control of a pneumatically actuated Stewart platform")
set(CPACK_DEBIAN_PACKAGE_DESCRIPTION
    "Six leg-controller processes (Backstepping-Sliding Mode or PI), a task-space\n\
supervisor and a plant simulator or hardware I/O node exchange typed samples\n\
over Eclipse Cyclone DDS, in lockstep or at 1 kHz in real time; a recorder\n\
writes MCAP. hexa_deploy turns a deployment description into per-host Cyclone\n\
DDS configuration, systemd units and DDS Security files.")
set(CPACK_DEBIAN_PACKAGE_SECTION misc)
set(CPACK_DEBIAN_PACKAGE_PRIORITY optional)
set(CPACK_DEBIAN_PACKAGE_SHLIBDEPS ON)
# python3-matplotlib: hexa_session's report draws the plots (a failed report fails the session).
set(CPACK_DEBIAN_PACKAGE_DEPENDS "adduser, openssl, python3, python3-matplotlib")
set(CPACK_DEBIAN_PACKAGE_RECOMMENDS "nftables")
set(CPACK_DEBIAN_PACKAGE_CONTROL_EXTRA
    "${HEXA_PKG_DIR}/postinst;${HEXA_PKG_DIR}/prerm;${HEXA_PKG_DIR}/postrm;${HEXA_PKG_CONFFILES}")
set(CPACK_DEBIAN_PACKAGE_CONTROL_STRICT_PERMISSION TRUE)
set(CPACK_STRIP_FILES TRUE)
# xz compression of ~100 MB of programs is most of the packaging time: on every core.
set(CPACK_THREADS 0)
set(CPACK_DEBIAN_FILE_NAME DEB-DEFAULT)
set(CPACK_PACKAGING_INSTALL_PREFIX /usr)
include(CPack)

#!/bin/bash
# Test credentials for DDS Security (Fast DDS builtin plugins: PKI-DH authentication,
# Access-Permissions access control, AES-GCM-GMAC encryption). FOR TESTS AND LOCAL USE ONLY:
# unencrypted private keys, one CA for identities and permissions.
#
#   scripts/make_dds_certs.sh OUT_DIR [NAME ...]     (default names: player detector slam mapper
#                                                     recorder bridge viewer)
# Writes:
#   OUT_DIR/ca/ca_cert.pem, ca_key.pem       test CA (ECDSA P-256 / SHA-256), identity +
#                                            permissions CA
#   OUT_DIR/governance.xml, governance.smime domain 0-232: no unauthenticated participants, join
#                                            access control, discovery / liveliness / RTPS
#                                            messages and data encrypted, read+write access
#                                            control on every topic; signed by the CA
#   OUT_DIR/<name>/cert.pem, key.pem         identity "CN=dygslam <name>,O=dygslam test"
#   OUT_DIR/<name>/permissions.xml, .smime   may publish and subscribe every topic on domains
#                                            0-232 for 1 year; everything else denied; signed
#   OUT_DIR/rogue/...                        an identity + permissions from ANOTHER CA (valid
#                                            files, wrong trust anchor) for negative tests
# Use: dygslam component ... with DYGSLAM_DDS_SECURITY_DIR=OUT_DIR/<name> (see
# components/dds/security.h), or SecurityOptions::FromDirectory(OUT_DIR/<name>).
set -euo pipefail
out=${1:?usage: make_dds_certs.sh OUT_DIR [NAME ...]}
shift
names=("$@")
[ ${#names[@]} -eq 0 ] && names=(player detector slam mapper recorder bridge viewer)
command -v openssl >/dev/null || { echo "make_dds_certs.sh: openssl not found" >&2; exit 1; }
mkdir -p "$out"
out=$(cd "$out" && pwd)
days=365
not_before=$(date -u -d '-1 day' +%Y-%m-%dT%H:%M:%S)
not_after=$(date -u -d "+$days days" +%Y-%m-%dT%H:%M:%S)

make_ca() {  # dir subject
  mkdir -p "$1"
  openssl ecparam -name prime256v1 -genkey -noout -out "$1/ca_key.pem" 2>/dev/null
  openssl req -x509 -new -sha256 -key "$1/ca_key.pem" -days $days -subj "$2" \
    -addext "basicConstraints=critical,CA:TRUE" -addext "keyUsage=critical,keyCertSign,cRLSign,digitalSignature" \
    -out "$1/ca_cert.pem"
}

sign() {  # ca_dir in.xml out.smime
  openssl smime -sign -in "$2" -text -out "$3" -signer "$1/ca_cert.pem" -inkey "$1/ca_key.pem"
}

make_identity() {  # ca_dir dir cn
  local ca=$1 dir=$2 cn=$3
  mkdir -p "$dir"
  local subject="/O=dygslam test/CN=$cn"
  openssl ecparam -name prime256v1 -genkey -noout -out "$dir/key.pem" 2>/dev/null
  openssl req -new -sha256 -key "$dir/key.pem" -subj "$subject" -out "$dir/cert.csr"
  openssl x509 -req -sha256 -in "$dir/cert.csr" -CA "$ca/ca_cert.pem" -CAkey "$ca/ca_key.pem" \
    -CAcreateserial -days $days -out "$dir/cert.pem" 2>/dev/null
  rm -f "$dir/cert.csr"
  cp "$ca/ca_cert.pem" "$dir/ca_cert.pem"
  # Subject as Fast DDS compares it (RFC 2253 order of the certificate).
  local sn
  sn=$(openssl x509 -in "$dir/cert.pem" -noout -subject -nameopt RFC2253 | sed 's/^subject=//')
  cat > "$dir/permissions.xml" <<XML
<?xml version="1.0" encoding="UTF-8"?>
<dds xmlns:xsi="http://www.w3.org/2001/XMLSchema-instance"
     xsi:noNamespaceSchemaLocation="http://www.omg.org/spec/DDS-SECURITY/20170901/omg_shared_ca_permissions.xsd">
  <permissions>
    <grant name="${cn// /_}">
      <subject_name>$sn</subject_name>
      <validity>
        <not_before>$not_before</not_before>
        <not_after>$not_after</not_after>
      </validity>
      <allow_rule>
        <domains><id_range><min>0</min><max>232</max></id_range></domains>
        <publish><topics><topic>*</topic></topics><partitions><partition>*</partition></partitions></publish>
        <subscribe><topics><topic>*</topic></topics><partitions><partition>*</partition></partitions></subscribe>
      </allow_rule>
      <default>DENY</default>
    </grant>
  </permissions>
</dds>
XML
  sign "$ca" "$dir/permissions.xml" "$dir/permissions.smime"
}

make_governance() {  # ca_dir dir
  cat > "$2/governance.xml" <<'XML'
<?xml version="1.0" encoding="UTF-8"?>
<dds xmlns:xsi="http://www.w3.org/2001/XMLSchema-instance"
     xsi:noNamespaceSchemaLocation="http://www.omg.org/spec/DDS-SECURITY/20170901/omg_shared_ca_governance.xsd">
  <domain_access_rules>
    <domain_rule>
      <domains><id_range><min>0</min><max>232</max></id_range></domains>
      <allow_unauthenticated_participants>false</allow_unauthenticated_participants>
      <enable_join_access_control>true</enable_join_access_control>
      <discovery_protection_kind>ENCRYPT</discovery_protection_kind>
      <liveliness_protection_kind>ENCRYPT</liveliness_protection_kind>
      <rtps_protection_kind>ENCRYPT</rtps_protection_kind>
      <topic_access_rules>
        <topic_rule>
          <topic_expression>*</topic_expression>
          <enable_discovery_protection>true</enable_discovery_protection>
          <enable_liveliness_protection>true</enable_liveliness_protection>
          <enable_read_access_control>true</enable_read_access_control>
          <enable_write_access_control>true</enable_write_access_control>
          <metadata_protection_kind>ENCRYPT</metadata_protection_kind>
          <data_protection_kind>ENCRYPT</data_protection_kind>
        </topic_rule>
      </topic_access_rules>
    </domain_rule>
  </domain_access_rules>
</dds>
XML
  sign "$1" "$2/governance.xml" "$2/governance.smime"
}

make_ca "$out/ca" "/O=dygslam test/CN=dygslam test CA"
make_governance "$out/ca" "$out"
for n in "${names[@]}"; do
  make_identity "$out/ca" "$out/$n" "dygslam $n"
  cp "$out/governance.smime" "$out/$n/governance.smime"
done
# Another CA: valid-looking credentials that the domain's CA did not issue.
make_ca "$out/rogue_ca" "/O=dygslam test/CN=rogue CA"
make_identity "$out/rogue_ca" "$out/rogue" "dygslam rogue"
make_governance "$out/rogue_ca" "$out/rogue"
rm -f "$out"/ca/*.srl "$out"/rogue_ca/*.srl
echo "DDS Security test credentials in $out: ${names[*]} (+ rogue)"

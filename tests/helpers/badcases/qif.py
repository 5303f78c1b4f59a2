"""Bad inputs of ``camcmm gdt import-qif FILE.qif --out plan.yaml`` (issue 28). Ids start
with ``qif-``.

A file that is not a QIF 3.0 document (not XML, an image, another XML, an empty file),
that carries a DTD (the "billion laughs" entity bomb, an external entity), that is larger
than the reader's limit, that holds no feature camcmm can use, whose references are
broken (a feature's definition, a characteristic's definition, a datum's feature, an id
used twice) or
whose units are wrong (a millimetre converting by 0.01, a ``linearUnit`` not declared, a
factor of zero) is refused, one line naming the file; so is a bad ``--out``. A file
whose characteristic camcmm does not evaluate is imported with the item skipped and a
warning (exit 0).

:func:`mini_qif` builds the small valid document every case edits (also used by
tests/gdt/test_qif_import.py): a plane A (z = 0, a 40 × 20 mm polyline), a bore of
Ø``diameter`` from (10, 10, 0) down 15 mm, a diameter ±0.02 and a flatness 0.05.
"""

from __future__ import annotations

from helpers.badinputs import BAD_UTF8, Case, png

QIF, OUT = "part.qif", "plan.yaml"


def mini_qif(
    *,
    unit: str = "mm",
    factor: str = "0.001",
    pmi_unit: str = "",
    diameter: str = "10",
    feature_definition: str = "2",
    char_definition: str = "10",
    datum_feature: str = "3",
    tol_unit: str = "",
    extra_chars: str = "",
    features: bool = True,
    head: str = "",
) -> bytes:
    """A minimal QIF 3.0 MBD (see the module docstring); the keywords break one thing."""
    pmi = (
        f"<PMILinearUnit><SIUnitName>meter</SIUnitName><UnitName>{pmi_unit}</UnitName>"
        f"<UnitConversion><Factor>0.0254</Factor></UnitConversion></PMILinearUnit>"
        if pmi_unit
        else ""
    )
    tu = f' linearUnit="{tol_unit}"' if tol_unit else ""
    feats = f"""
  <Features>
    <FeatureDefinitions n="2">
      <PlaneFeatureDefinition id="1"></PlaneFeatureDefinition>
      <CylinderFeatureDefinition id="2"><InternalExternal>INTERNAL</InternalExternal>
        <Diameter>{diameter}</Diameter><Length>15</Length></CylinderFeatureDefinition>
    </FeatureDefinitions>
    <FeatureNominals n="2">
      <PlaneFeatureNominal id="3"><FeatureDefinitionId>1</FeatureDefinitionId>
        <Location>0 0 0</Location><Normal>0 0 1</Normal>
        <PolyLine count="4">0 0 0 40 0 0 40 20 0 0 20 0</PolyLine></PlaneFeatureNominal>
      <CylinderFeatureNominal id="4"><FeatureDefinitionId>{feature_definition}</FeatureDefinitionId>
        <Axis><AxisPoint>10 10 0</AxisPoint><Direction>0 0 -1</Direction></Axis></CylinderFeatureNominal>
    </FeatureNominals>
  </Features>"""
    return f"""<?xml version="1.0" encoding="utf-8"?>{head}
<QIFDocument xmlns="http://qifstandards.org/xsd/qif3" versionQIF="3.0.0" idMax="20">
  <FileUnits><PrimaryUnits>
    <LinearUnit><SIUnitName>meter</SIUnitName><UnitName>{unit}</UnitName>
      <UnitConversion><Factor>{factor}</Factor></UnitConversion></LinearUnit>{pmi}
  </PrimaryUnits></FileUnits>
  <DatumDefinitions n="1"><DatumDefinition id="5"><DatumLabel>A</DatumLabel>
    <FeatureNominalIds n="1"><Id>{datum_feature}</Id></FeatureNominalIds></DatumDefinition></DatumDefinitions>
  <DatumReferenceFrames n="1"><DatumReferenceFrame id="6"><Datums n="1"><Datum>
    <SimpleDatum><DatumDefinitionId>5</DatumDefinitionId></SimpleDatum>
    <Precedence><PrecedenceEnum>PRIMARY</PrecedenceEnum></Precedence></Datum></Datums>
  </DatumReferenceFrame></DatumReferenceFrames>{feats if features else ""}
  <Characteristics>
    <CharacteristicDefinitions n="2">
      <DiameterCharacteristicDefinition id="10"><Tolerance>
        <MaxValue{tu}>0.02</MaxValue><MinValue{tu}>-0.02</MinValue><DefinedAsLimit>false</DefinedAsLimit>
      </Tolerance></DiameterCharacteristicDefinition>
      <FlatnessCharacteristicDefinition id="11"><ToleranceValue{tu}>0.05</ToleranceValue>
      </FlatnessCharacteristicDefinition>
    </CharacteristicDefinitions>
    <CharacteristicNominals n="2">
      <DiameterCharacteristicNominal id="12"><CharacteristicDefinitionId>{char_definition}</CharacteristicDefinitionId>
        <FeatureNominalIds n="1"><Id>4</Id></FeatureNominalIds><Name>Size.1</Name></DiameterCharacteristicNominal>
      <FlatnessCharacteristicNominal id="13"><CharacteristicDefinitionId>11</CharacteristicDefinitionId>
        <FeatureNominalIds n="1"><Id>3</Id></FeatureNominalIds></FlatnessCharacteristicNominal>{extra_chars}
    </CharacteristicNominals>
  </Characteristics>
</QIFDocument>
""".encode()


#: The XML entity bomb: 10 levels of 10 references, 10^9 "lol" if expanded.
BILLION_LAUGHS = (
    b'<?xml version="1.0"?>\n<!DOCTYPE lolz [\n <!ENTITY lol "lol">\n'
    + b"".join(
        f' <!ENTITY lol{i} "{("&lol" + (str(i - 1) if i > 1 else "") + ";") * 10}">\n'.encode() for i in range(1, 10)
    )
    + b']>\n<QIFDocument xmlns="http://qifstandards.org/xsd/qif3">&lol9;</QIFDocument>\n'
)
EXTERNAL_ENTITY = (
    b'<?xml version="1.0"?>\n<!DOCTYPE q [<!ENTITY x SYSTEM "file:///etc/passwd">]>\n'
    b'<QIFDocument xmlns="http://qifstandards.org/xsd/qif3">&x;</QIFDocument>\n'
)
#: An angle characteristic (not a camcmm characteristic): imported with it skipped.
ANGLE = """
      <AngleCharacteristicNominal id="14"><CharacteristicDefinitionId>11</CharacteristicDefinitionId>
        <FeatureNominalIds n="1"><Id>3</Id></FeatureNominalIds></AngleCharacteristicNominal>"""


#: A second element with the cylinder's id 4: every reference to 4 would be ambiguous.
DUPLICATE_ID = """
      <FlatnessCharacteristicNominal id="4"><CharacteristicDefinitionId>11</CharacteristicDefinitionId>
        <FeatureNominalIds n="1"><Id>3</Id></FeatureNominalIds></FlatnessCharacteristicNominal>"""


def _case(cid: str, data: bytes | None, names: tuple[str, ...], *opts: str, out: str = OUT) -> Case:
    files = {} if data is None else {QIF: data}
    return Case(f"qif-{cid}", ("gdt", "import-qif", QIF, "--out", out, *opts, "--json"), files, names)


def cases() -> list[Case]:
    huge = mini_qif() + b" " * (64 * 1024 * 1024 + 1 - len(mini_qif()))
    return [
        _case("missing", None, (QIF,)),
        _case("empty", b"", (QIF,)),
        _case("not-xml", b"features: [1, 2]\n", (QIF,)),
        _case("an-image", png(4, 4), (QIF,)),
        _case("bad-utf8", b"<?xml version='1.0' encoding='utf-8'?><a>" + BAD_UTF8 + b"</a>", (QIF,)),
        _case("truncated", mini_qif()[:600], (QIF,)),
        _case("not-qif", b'<?xml version="1.0"?><svg xmlns="http://www.w3.org/2000/svg"/>', (QIF,)),
        _case("billion-laughs", BILLION_LAUGHS, (QIF,)),
        _case("external-entity", EXTERNAL_ENTITY, (QIF,)),
        _case("huge", huge, (QIF,)),
        _case("no-features", mini_qif(features=False), (QIF,)),
        _case("broken-feature-definition", mini_qif(feature_definition="99"), (QIF, "99")),
        _case("broken-characteristic-definition", mini_qif(char_definition="98"), (QIF, "98")),
        _case("broken-datum-feature", mini_qif(datum_feature="97"), (QIF, "97")),
        _case("duplicate-id", mini_qif(extra_chars=DUPLICATE_ID), (QIF, "id 4")),
        _case("wrong-unit-factor", mini_qif(factor="0.01"), (QIF, "Factor")),
        _case("zero-unit-factor", mini_qif(unit="furlong", factor="0"), (QIF, "Factor")),
        _case("unit-not-a-number", mini_qif(factor="one"), (QIF, "Factor")),
        _case("undeclared-linear-unit", mini_qif(tol_unit="cubit"), (QIF, "cubit")),
        _case("diameter-negative", mini_qif(diameter="-10"), (QIF, "diameter")),
        _case("diameter-text", mini_qif(diameter="ten"), (QIF, "ten")),
        _case("out-wrong-suffix", mini_qif(), ("--out",), out="plan.txt"),
        _case("out-no-folder", mini_qif(), ("--out",), out="nowhere/plan.yaml"),
        _case("angle-skipped", mini_qif(extra_chars=ANGLE), ()),
    ]
